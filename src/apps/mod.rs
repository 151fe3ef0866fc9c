//! Applications built on the statistics: the dissertation's hypothesis tests on plant clutter
//! (ch. 5.1). The deep-learning applications of ch. 5.3 belong here too.

pub mod hypotheses;
