//! Running an experiment: the plan (sweep expansion, job ids, seeds from identities), the job
//! kinds behind one seam ([`jobs`]), every job's memory and work estimated before anything is
//! allocated ([`estimate`]) and the plan checked against the machine ([`check`]), the scheduler that fans jobs out over a thread pool (a whole run
//! or one shard), the durable job store every finished job is saved in ([`store`]: resume,
//! shards), the merge of the store into the Parquet tables ([`merge`], streamed by [`assembly`]), the manifest, and the
//! Slurm scripts that run a spec's shards as an array job and merge them ([`slurm`]).

pub mod assembly;
pub mod check;
pub mod driver;
pub mod estimate;
pub mod ids;
pub mod jobs;
pub mod manifest;
pub mod merge;
pub mod params;
pub mod plan;
pub mod result;
pub mod scheduler;
pub mod slurm;
pub mod store;
pub mod tables;
