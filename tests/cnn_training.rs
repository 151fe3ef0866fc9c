//! Training options that follow MATLAB's `trainingOptions` (docs/cnn.md): validation every
//! `validation_frequency` iterations as a record only, the training set shuffled once or
//! before every epoch, and the equal-steps protocol beside MATLAB's.

mod common;

use isar_clutter::apps::cnn::train::{train, Protocol, Shuffle, Trained, TrainingOptions};

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

/// The equal-steps protocol (docs/cnn.md): a small and a large set take the same number of
/// mini-batch steps (by default what the largest set takes in `epochs` epochs), reshuffled
/// before every epoch, the last epoch cut short; MATLAB's protocol gives the small set fewer.
/// `steps` under MATLAB's protocol is refused, naming the key.
#[test]
fn equal_steps_give_every_set_the_same_steps() {
    let c = common::toy_net();
    let (small, va) = common::toy_sets(11, 20, 8, 1.0);
    let matlab = TrainingOptions {
        batch_size: 8,
        epochs: 2,
        ..TrainingOptions::default()
    };
    // 20 samples in batches of 8: 2 steps an epoch; 50: 6.
    assert_eq!((matlab.steps_for(20), matlab.steps_for(50)), (4, 12));
    let equal = TrainingOptions {
        protocol: Protocol::EqualSteps,
        ..matlab
    }
    .for_largest(50);
    assert_eq!(equal.steps, Some(12));
    assert_eq!((equal.steps_for(20), equal.steps_for(50)), (12, 12));
    let e = train(&c, &equal, &small, &va, 5);
    assert_eq!(e.epochs.len(), 6, "12 steps at 2 an epoch");
    // MATLAB's protocol over as many epochs: the same first epoch, then other batches (the
    // equal-steps set is reshuffled).
    let once = TrainingOptions {
        epochs: 6,
        ..matlab
    };
    let m = train(&c, &once, &small, &va, 5);
    assert_eq!(m.epochs.len(), 6);
    assert_eq!(m.epochs[0].loss.to_bits(), e.epochs[0].loss.to_bits());
    assert_ne!(m.epochs[1].loss.to_bits(), e.epochs[1].loss.to_bits());
    // 5 steps: three epochs, the last one step long (its loss that of its first batch alone,
    // where 6 steps average two).
    let five = train(
        &c,
        &TrainingOptions {
            steps: Some(5),
            ..equal
        },
        &small,
        &va,
        5,
    );
    let six = train(
        &c,
        &TrainingOptions {
            steps: Some(6),
            ..equal
        },
        &small,
        &va,
        5,
    );
    assert_eq!((five.epochs.len(), six.epochs.len()), (3, 3));
    assert_eq!(five.epochs[1].loss.to_bits(), six.epochs[1].loss.to_bits());
    assert_ne!(five.epochs[2].loss.to_bits(), six.epochs[2].loss.to_bits());
    let refused = TrainingOptions {
        steps: Some(5),
        ..matlab
    };
    assert_eq!(refused.check().unwrap_err().0, "steps");
}
