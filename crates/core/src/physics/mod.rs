//! The physics behind simulated data: the ISAR imaging chain (k-space to image), the Mie
//! series of a sphere, the measurement and calibration chain (background subtraction, time
//! gating, `a(f)`), and the wind-blown vegetation stand-in. Plain typed parameters in, arrays
//! out; no file I/O.

pub mod calibration;
pub mod isar;
pub mod mie;
pub mod trig;
pub mod vegetation;
