//! Which shard each input's group of jobs goes to: in turn, or balanced by cost.

use super::ShardBy;

/// The shard of each group given the groups' costs: in turn (group k to k mod `count`), or
/// greatest cost first onto the least-loaded shard, ties to the earlier group and the lower
/// shard, so every machine computes the same split (the longest-processing-time rule: no
/// shard ends more than the largest group above the even share).
pub(super) fn assign(costs: &[u64], count: usize, by: ShardBy) -> Vec<usize> {
    let count = count.max(1);
    match by {
        ShardBy::Order => (0..costs.len()).map(|g| g % count).collect(),
        ShardBy::Cost => {
            let mut order: Vec<usize> = (0..costs.len()).collect();
            // Stable: equal costs keep the manifest's order.
            order.sort_by(|&a, &b| costs[b].cmp(&costs[a]));
            let mut load = vec![0u64; count];
            let mut owner = vec![0; costs.len()];
            for g in order {
                let s = (0..count).min_by_key(|&s| (load[s], s)).unwrap_or(0);
                load[s] = load[s].saturating_add(costs[g]);
                owner[g] = s;
            }
            owner
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One large input among small ones gets a shard to itself; in turn it would not.
    #[test]
    fn a_large_input_gets_a_shard_of_its_own() {
        let costs = [10, 10, 640, 10, 10, 10, 10, 10];
        let owner = assign(&costs, 2, ShardBy::Cost);
        let load = |s| -> u64 {
            costs
                .iter()
                .zip(&owner)
                .filter(|(_, o)| **o == s)
                .map(|(c, _)| c)
                .sum()
        };
        assert_eq!((load(0), load(1)), (640, 70));
        assert_eq!(assign(&costs, 2, ShardBy::Order), [0, 1, 0, 1, 0, 1, 0, 1]);
    }

    /// Equal costs are dealt out in turn, in the manifest's order, and every group has a shard.
    #[test]
    fn equal_costs_deal_in_turn() {
        assert_eq!(assign(&[5; 5], 3, ShardBy::Cost), [0, 1, 2, 0, 1]);
        assert_eq!(assign(&[], 3, ShardBy::Cost), Vec::<usize>::new());
    }
}
