//! Shards of a dataset: `I/N` renders the images k with `k % N == I`; `--shard auto` takes the
//! shard a batch engine assigns ([`Shard::from_env`]).

use std::str::FromStr;

use super::DatasetError;

/// Shard `index` of `count`: the images k with `k % count == index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard, 0-based.
    pub index: u64,
    /// Number of shards.
    pub count: u64,
}

impl Shard {
    /// The whole dataset.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Whether image k belongs to this shard.
    pub fn contains(&self, k: u64) -> bool {
        self.count > 0 && k % self.count == self.index
    }
}

impl Shard {
    /// The shard a batch engine assigns, from its environment (`var` looks a variable up; the CLI
    /// passes `std::env::var`): a Slurm job array (`SLURM_ARRAY_TASK_ID` - `SLURM_ARRAY_TASK_MIN`
    /// of `SLURM_ARRAY_TASK_COUNT`), else a Kubernetes Indexed Job (`JOB_COMPLETION_INDEX` of
    /// `JOB_COMPLETIONS`, which the Job's manifest sets to its `completions`).
    ///
    /// # Errors
    /// [`DatasetError::InvalidArgument`] when neither is set, a value is not a number, or the index
    /// is out of range.
    pub fn from_env(var: &dyn Fn(&str) -> Option<String>) -> Result<Self, DatasetError> {
        let bad = |reason: String| DatasetError::InvalidArgument { what: "--shard auto".into(), reason };
        let num = |name: &str| -> Result<Option<u64>, DatasetError> {
            var(name).map(|v| v.trim().parse::<u64>().map_err(|_| bad(format!("{name} = `{v}` is not a number")))).transpose()
        };
        let (index, count, from) = if let (Some(id), Some(n)) = (num("SLURM_ARRAY_TASK_ID")?, num("SLURM_ARRAY_TASK_COUNT")?) {
            let min = num("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            (id.checked_sub(min).ok_or_else(|| bad(format!("SLURM_ARRAY_TASK_ID {id} < SLURM_ARRAY_TASK_MIN {min}")))?, n, "Slurm")
        } else if let (Some(i), Some(n)) = (num("JOB_COMPLETION_INDEX")?, num("JOB_COMPLETIONS")?) {
            (i, n, "Kubernetes")
        } else {
            return Err(bad("no batch engine in the environment: set SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT (a Slurm array) or JOB_COMPLETION_INDEX and JOB_COMPLETIONS (a Kubernetes Indexed Job)".into()));
        };
        if count == 0 || index >= count {
            return Err(bad(format!("{from}: index {index} of {count} shards")));
        }
        Ok(Shard { index, count })
    }
}

impl FromStr for Shard {
    type Err = DatasetError;

    /// `I/N` with 0 <= I < N.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |reason: &str| DatasetError::InvalidArgument { what: format!("--shard `{s}`"), reason: reason.into() };
        let (i, n) = s.split_once('/').ok_or_else(|| bad("expected I/N, e.g. 0/4"))?;
        let (index, count): (u64, u64) = (i.trim().parse().map_err(|_| bad("I is not a number"))?, n.trim().parse().map_err(|_| bad("N is not a number"))?);
        if count == 0 || index >= count {
            return Err(bad("needs N >= 1 and 0 <= I < N"));
        }
        Ok(Shard { index, count })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_from_slurm_or_kubernetes_environment() {
        let env = |pairs: &'static [(&'static str, &'static str)]| move |k: &str| pairs.iter().find(|(n, _)| *n == k).map(|(_, v)| (*v).to_string());
        let slurm = env(&[("SLURM_ARRAY_TASK_ID", "5"), ("SLURM_ARRAY_TASK_MIN", "3"), ("SLURM_ARRAY_TASK_COUNT", "4")]);
        assert_eq!(Shard::from_env(&slurm).unwrap(), Shard { index: 2, count: 4 });
        let k8s = env(&[("JOB_COMPLETION_INDEX", "1"), ("JOB_COMPLETIONS", "3")]);
        assert_eq!(Shard::from_env(&k8s).unwrap(), Shard { index: 1, count: 3 });
        assert!(Shard::from_env(&env(&[])).unwrap_err().to_string().contains("SLURM_ARRAY_TASK_ID"));
        assert!(Shard::from_env(&env(&[("JOB_COMPLETION_INDEX", "3"), ("JOB_COMPLETIONS", "3")])).is_err());
        assert!(Shard::from_env(&env(&[("JOB_COMPLETION_INDEX", "x"), ("JOB_COMPLETIONS", "3")])).unwrap_err().to_string().contains("x"));
    }

    #[test]
    fn shard_parses_and_partitions() {
        let s: Shard = "1/4".parse().unwrap();
        assert_eq!(s, Shard { index: 1, count: 4 });
        assert!(s.contains(5) && !s.contains(4));
        for bad in ["4/4", "1", "a/2", "0/0", "-1/3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}
