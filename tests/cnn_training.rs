//! Training options that follow MATLAB's `trainingOptions` (docs/cnn.md): validation every
//! `validation_frequency` iterations as a record only, and the training set shuffled once or
//! before every epoch.

mod common;

use isar_clutter::apps::cnn::train::{train, Shuffle, Trained, TrainingOptions};

/// MATLAB's `ValidationFrequency` and `Shuffle`: validation every `validation_frequency`
/// iterations and after the last changes nothing in the network (only the record), and
/// shuffling once gives the first epoch of shuffling every epoch, then other batches.
#[test]
fn validation_is_a_record_and_shuffle_once_keeps_the_first_order() {
    let c = common::toy_net();
    let (tr, va) = common::toy_sets(11, 40, 16, 1.0);
    // 40 samples in batches of 8: 5 iterations an epoch, 15 in all.
    let base = TrainingOptions {
        batch_size: 8,
        epochs: 3,
        validation_frequency: 4,
        ..TrainingOptions::default()
    };
    let a = train(&c, &base, &tr, &va, 5);
    // Validations at iterations 4 (epoch 1), 8 (epoch 2), 12 and 15 (epoch 3).
    // Whether each epoch had a validation.
    let validated = |t: &Trained| -> Vec<bool> {
        t.epochs
            .iter()
            .map(|e| e.validation_accuracy.is_some())
            .collect()
    };
    assert_eq!(validated(&a), [true, true, true]);
    let sparse = TrainingOptions {
        validation_frequency: 7,
        ..base
    };
    let b = train(&c, &sparse, &tr, &va, 5);
    // Iterations 7 (epoch 2), 14 and 15 (epoch 3): none in epoch 1.
    assert_eq!(validated(&b), [false, true, true]);
    let w = |t: &Trained| -> Vec<f32> { t.net.fc_w.val().into_data().to_vec().unwrap() };
    assert_eq!(w(&a), w(&b), "validation changed the network");
    assert_eq!(
        a.validation_accuracy.to_bits(),
        b.validation_accuracy.to_bits()
    );
    let every = TrainingOptions {
        shuffle: Shuffle::EveryEpoch,
        ..base
    };
    let e = train(&c, &every, &tr, &va, 5);
    assert_eq!(a.epochs[0].loss.to_bits(), e.epochs[0].loss.to_bits());
    assert_ne!(a.epochs[1].loss.to_bits(), e.epochs[1].loss.to_bits());
    assert_ne!(w(&a), w(&e));
}
