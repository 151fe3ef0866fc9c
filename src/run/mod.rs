//! Running an experiment: the plan (sweep expansion, job ids, seeds from identities), the job
//! kinds behind one seam ([`jobs`]), every job's memory and work estimated before anything is
//! allocated ([`estimate`]), the scheduler that fans jobs out over a thread pool, the
//! table assembly that turns the jobs' result rows into Parquet tables, the manifest, and the
//! Slurm scripts that run a spec's shards as an array job ([`slurm`]).

pub mod estimate;
pub mod jobs;
pub mod manifest;
pub mod plan;
pub mod result;
pub mod scheduler;
pub mod slurm;
pub mod tables;
