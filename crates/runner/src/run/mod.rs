//! Running an experiment: the plan (sweep expansion, job ids, seeds from identities), the job
//! kinds behind one seam ([`jobs`]), every job's memory and work estimated before anything is
//! allocated ([`estimate`]) and the plan checked against the machine ([`check`]); the one value
//! a run is ([`value::Run`]: plan, jobs, keys, options), whose methods are the driver's
//! ([`driver`]), the scheduler's (fans jobs out over a thread pool: a whole run or one shard,
//! [`scheduler`]) and the merge's steps ([`merge`]: the store into the Parquet tables, streamed
//! by [`assembly`]); the run's [`options`], where its CNN trainings run ([`training_device`]), the folder's record of its spec ([`record`]), the
//! durable job store every finished job is saved in ([`store`]: resume, shards), the jobs'
//! states ([`status`]), the manifest, and the Slurm scripts that run a spec's shards as an
//! array job and merge them ([`slurm`], their `--time` and `--mem` checked by [`slurm_values`]).

pub mod assembly;
pub mod check;
pub mod driver;
pub mod estimate;
pub mod ids;
pub mod jobs;
pub mod manifest;
pub mod merge;
pub mod options;
pub mod params;
pub mod plan;
pub mod record;
pub mod result;
pub mod scheduler;
pub mod slurm;
pub mod slurm_values;
pub mod status;
pub mod store;
pub mod tables;
pub mod training_device;
pub mod value;
