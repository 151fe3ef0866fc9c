//! Applications built on the statistics: the dissertation's hypothesis tests on plant clutter
//! (ch. 5.1) and its deep-learning applications (ch. 5.3: clutter classification and target
//! location with CNNs trained on generated clutter).

pub mod cnn;
pub mod hypotheses;
