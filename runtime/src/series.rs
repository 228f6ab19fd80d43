//! What each step of a run cost, for per-step series (`run --series`) and sweeps: the
//! statistics' growth over the step, the agents that executed a rule, and the records by
//! kind. Summed over the steps of a run, every column equals the run's [`Stats`] total.

use crate::engine::{Stats, StepReport};
use crate::record::RecordKind;

/// The cost of one step.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct StepCost {
    /// The step (from 1).
    pub step: u64,
    /// Executions per rule (file order).
    pub firings: Vec<u64>,
    /// Agents that executed a rule.
    pub executing: u64,
    /// Agent moves (each agent of a moved group counts).
    pub moves: u64,
    /// Of the moves, agents carried by their group.
    pub carried: u64,
    /// Swaps done.
    pub swaps: u64,
    /// Messages sent, delivered and dropped.
    pub sent: u64,
    /// Messages delivered.
    pub delivered: u64,
    /// Messages dropped.
    pub dropped: u64,
    /// Records per kind, in the order of [`RecordKind::ALL`].
    pub records: Vec<u64>,
}

impl StepCost {
    /// The cost of the step that took the statistics from `before` to `after` and
    /// reported `rep`.
    pub fn of(before: &Stats, after: &Stats, rep: &StepReport) -> StepCost {
        // (From the counts: a report may keep only a step's first records of each kind.)
        let count = |s: &Stats, k: &RecordKind| s.records.get(k).copied().unwrap_or(0);
        let records = (RecordKind::ALL.iter())
            .map(|k| count(after, k) - count(before, k))
            .collect();
        StepCost {
            step: after.steps,
            firings: (after.firings.iter())
                .zip(&before.firings)
                .map(|(a, b)| a - b)
                .collect(),
            executing: rep.executing,
            moves: after.moves - before.moves,
            carried: after.carried - before.carried,
            swaps: after.swaps - before.swaps,
            sent: after.sent - before.sent,
            delivered: after.delivered - before.delivered,
            dropped: after.dropped - before.dropped,
            records,
        }
    }

    /// The totals of a whole run: its statistics, and `executing` summed over its steps
    /// (`step` is then the number of steps).
    pub fn total(stats: &Stats, executing: u64) -> StepCost {
        StepCost {
            step: stats.steps,
            firings: stats.firings.clone(),
            executing,
            moves: stats.moves,
            carried: stats.carried,
            swaps: stats.swaps,
            sent: stats.sent,
            delivered: stats.delivered,
            dropped: stats.dropped,
            records: (RecordKind::ALL.iter())
                .map(|k| stats.records.get(k).copied().unwrap_or(0))
                .collect(),
        }
    }

    /// All firings of the step.
    pub fn all_firings(&self) -> u64 {
        self.firings.iter().sum()
    }

    /// All records of the step.
    pub fn all_records(&self) -> u64 {
        self.records.iter().sum()
    }

    /// The names of the columns of a series of a program whose rules are named `rules`:
    /// `step`, `firings`, then `firings:NAME` per rule, `executing`, `moves`, `carried`,
    /// `swaps`, `sent`, `delivered`, `dropped`, `records`, and `records:KIND` per kind.
    pub fn columns(rules: &[&str]) -> Vec<String> {
        let mut c = vec!["step".to_string(), "firings".into()];
        c.extend(rules.iter().map(|r| format!("firings:{r}")));
        for name in [
            "executing",
            "moves",
            "carried",
            "swaps",
            "sent",
            "delivered",
            "dropped",
            "records",
        ] {
            c.push(name.into());
        }
        c.extend(
            RecordKind::ALL
                .iter()
                .map(|k| format!("records:{}", k.name())),
        );
        c
    }

    /// The step's values in the order of [`StepCost::columns`].
    pub fn values(&self) -> Vec<u64> {
        let mut v = vec![self.step, self.all_firings()];
        v.extend(&self.firings);
        v.extend([
            self.executing,
            self.moves,
            self.carried,
            self.swaps,
            self.sent,
            self.delivered,
            self.dropped,
            self.all_records(),
        ]);
        v.extend(&self.records);
        v
    }

    /// The cost whose [`StepCost::values`] are `v`, for a program of `rules` rules (a row
    /// of a table read back); `None` when `v` has not the length of its columns or its sums
    /// (all firings, all records) do not add up.
    pub fn from_values(rules: usize, v: &[u64]) -> Option<StepCost> {
        let kinds = RecordKind::ALL.len();
        if v.len() != 2 + rules + 8 + kinds {
            return None;
        }
        let at = |i: usize| v[2 + rules + i];
        let c = StepCost {
            step: v[0],
            firings: v[2..2 + rules].to_vec(),
            executing: at(0),
            moves: at(1),
            carried: at(2),
            swaps: at(3),
            sent: at(4),
            delivered: at(5),
            dropped: at(6),
            records: v[2 + rules + 8..].to_vec(),
        };
        (c.values() == v).then_some(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every value has its column, in order.
    #[test]
    fn values_follow_the_columns() {
        let c = StepCost {
            step: 3,
            firings: vec![2, 5],
            executing: 6,
            moves: 4,
            carried: 1,
            swaps: 1,
            sent: 9,
            delivered: 7,
            dropped: 2,
            records: (0..RecordKind::ALL.len() as u64).collect(),
        };
        let cols = StepCost::columns(&["a", "b"]);
        let vals = c.values();
        assert_eq!(cols.len(), vals.len());
        let at = |name: &str| vals[cols.iter().position(|c| c == name).unwrap()];
        assert_eq!((at("step"), at("firings"), at("firings:b")), (3, 7, 5));
        assert_eq!((at("carried"), at("dropped")), (1, 2));
        let swap_target = RecordKind::SwapTarget as u64;
        assert_eq!(at("records:swap-target"), swap_target);
        assert_eq!(at("records"), c.records.iter().sum::<u64>());
        assert_eq!(StepCost::from_values(2, &vals), Some(c));
        assert_eq!(StepCost::from_values(1, &vals), None, "not of 1 rule");
        let mut wrong = vals.clone();
        wrong[1] += 1;
        assert_eq!(
            StepCost::from_values(2, &wrong),
            None,
            "firings do not add up"
        );
    }
}
