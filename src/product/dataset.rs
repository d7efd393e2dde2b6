//! The dataset: a deterministic train/val/test split and the Ultralytics layout
//! (`images/{train,val,test}`, `labels/{train,val,test}`, `data.yaml`).

use rand::RngExt;
use serde::Serialize;

use crate::rng::{Purpose, stream};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, PartialOrd, Ord)]
#[serde(rename_all = "lowercase")]
pub enum Subset {
    Train,
    Val,
    Test,
}

impl Subset {
    pub fn name(self) -> &'static str {
        match self {
            Subset::Train => "train",
            Subset::Val => "val",
            Subset::Test => "test",
        }
    }
}

/// The subset of every image: counts are round(n * ratio) for train and val, the rest test;
/// which images go where is a seeded shuffle, so it depends on nothing but (seed, n, ratios).
pub fn assign(seed: u64, n: usize, train: f64, val: f64) -> Vec<Subset> {
    let n_train = ((n as f64) * train).round() as usize;
    let n_val = (((n as f64) * val).round() as usize).min(n - n_train.min(n));
    let n_train = n_train.min(n);
    let mut order: Vec<usize> = (0..n).collect();
    let mut rng = stream(seed, 0, Purpose::Split);
    // Fisher-Yates.
    for i in (1..n).rev() {
        let j = rng.random_range(0..=i);
        order.swap(i, j);
    }
    let mut subsets = vec![Subset::Test; n];
    for (rank, &image) in order.iter().enumerate() {
        subsets[image] = if rank < n_train {
            Subset::Train
        } else if rank < n_train + n_val {
            Subset::Val
        } else {
            Subset::Test
        };
    }
    subsets
}

/// The subset of every image when images come in collects of `frames` (image i in collect
/// i / frames): the collects are assigned as `assign` assigns images, and every frame goes
/// with its collect, so no collect is split between train and test. One frame per collect is
/// `assign` itself.
pub fn assign_collects(seed: u64, n: usize, frames: usize, train: f64, val: f64) -> Vec<Subset> {
    let frames = frames.max(1);
    let collects = assign(seed, n.div_ceil(frames), train, val);
    (0..n).map(|i| collects[i / frames]).collect()
}

/// `data.yaml` for Ultralytics. It names no `path`, so Ultralytics takes the folder of the YAML
/// file itself: the dataset trains from wherever it is moved, and its hash does not depend on
/// the output directory.
pub fn data_yaml(campaign_name: &str, campaign_hash: &str) -> String {
    format!(
        "# Ultralytics dataset written by soig, campaign `{campaign_name}` ({campaign_hash})\n\
         train: images/train\n\
         val: images/val\n\
         test: images/test\n\
         nc: 1\n\
         names:\n  0: debris\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_counts_and_determinism() {
        // The paper's 70/20/10.
        let a = assign(7, 100, 0.7, 0.2);
        assert_eq!(a, assign_collects(7, 100, 1, 0.7, 0.2));
        // Collects of 5: every frame in its collect's subset, the collects split 70/20/10.
        let c = assign_collects(7, 100, 5, 0.7, 0.2);
        for k in 0..20 {
            assert!(
                c[5 * k..5 * k + 5].iter().all(|&s| s == c[5 * k]),
                "collect {k}"
            );
        }
        assert_eq!(c.iter().filter(|&&s| s == Subset::Train).count(), 70);
        assert_eq!(c.iter().filter(|&&s| s == Subset::Val).count(), 20);
        assert_eq!(a, assign(7, 100, 0.7, 0.2));
        assert_ne!(a, assign(8, 100, 0.7, 0.2));
        let count = |s| a.iter().filter(|&&x| x == s).count();
        assert_eq!(
            (
                count(Subset::Train),
                count(Subset::Val),
                count(Subset::Test)
            ),
            (70, 20, 10)
        );
        let small = assign(1, 3, 0.7, 0.2);
        assert_eq!(small.len(), 3);
        let all_train = assign(1, 5, 1.0, 0.0);
        assert!(all_train.iter().all(|&s| s == Subset::Train));
    }
}
