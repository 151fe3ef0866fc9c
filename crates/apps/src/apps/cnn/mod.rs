//! The deep-learning applications of the dissertation's chapter 5.3 (docs/definitions.md §12):
//! small CNNs trained on generated clutter and tested on original data. [`net`] holds the
//! networks of Tables 18 and 23, [`train`] the training loop (MATLAB's `sgdm` defaults) on
//! burn's pure-Rust CPU backend ([`device`] chooses where a training runs), [`classification`] and [`location`] the two applications'
//! data sets (splits, normalisation, the mix of generated and original samples, targets and
//! signal-to-clutter ratio), [`store`] saving and loading trained networks, and [`fast`] the
//! hand-written CPU kernels of the convolution blocks ([`geom`] their geometry, [`im2col`] their
//! im2col matrices, [`parity`] the stride-2 convolutions of prediction without them, [`sgemm`]
//! their matrix products), and with the `cuda` feature [`gpu`] the cuDNN route of training on an
//! NVIDIA GPU.

pub mod classification;
pub mod device;
pub mod fast;
pub mod geom;
#[cfg(feature = "cuda")]
pub mod gpu;
#[cfg(not(feature = "cuda"))]
#[path = "gpu/layout.rs"]
#[allow(dead_code)]
mod gpu_layout;
pub mod im2col;
pub mod location;
pub mod net;
pub mod parity;
pub mod sgemm;
pub mod store;
pub mod train;
