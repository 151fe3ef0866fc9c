//! The numerical kernels of the statistics: the multiscale Haar analysis (ch. 3), correlating
//! filters and their exact correlations, the similarity metrics (KL, CMD, multiscale RMSE), the
//! low-rank and Fleishman samplers, a small minimiser for the calibration fits, and the slow oracles the fast kernels are tested against.
//! Everything here takes plain typed parameters and array views and does no file I/O; work runs
//! on the caller's rayon pool, never on a pool of its own.

pub mod analysis;
pub mod cmd;
pub mod filters;
pub mod fleishman;
pub mod lowrank;
pub mod metrics;
pub mod optimise;
pub mod oracle;
pub mod similarity;
