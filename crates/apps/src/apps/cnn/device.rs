//! Where a training runs (`training.device`): the CPU ([`super::train::train`]), or with the
//! `cuda` feature an NVIDIA GPU, by the cuDNN route ([`super::gpu`]) for SGDM or burn's CUDA
//! backend (Adam, or `ISAR_CLUTTER_CUDA_ROUTE=burn`). The driver is checked before anything
//! touches CUDA, and a panic inside a CUDA library comes back as an error.

use super::net::NetConfig;
use super::train::{train, Device, Labelled, Trained, TrainingOptions};
#[cfg(feature = "cuda")]
use super::train::{train_on, Optimiser};

/// [`train`] on the device the options name (`cpu`, or `cuda` in a binary built with the
/// `cuda` feature).
///
/// # Errors
/// For `cuda`: a binary without the feature, no loadable NVIDIA driver, or a failure inside
/// the CUDA backend (which burn reports by panicking; it is caught here).
pub fn train_on_device(
    cfg: &NetConfig,
    opts: &TrainingOptions,
    train_set: &Labelled,
    validation: &Labelled,
    seed: u64,
) -> anyhow::Result<Trained> {
    match opts.device {
        Device::Cpu => Ok(train(cfg, opts, train_set, validation, seed)),
        Device::Cuda => cuda::train(cfg, opts, train_set, validation, seed),
        Device::Auto => {
            let opts = TrainingOptions {
                device: resolve(Device::Auto)?.0,
                ..*opts
            };
            train_on_device(cfg, &opts, train_set, validation, seed)
        }
    }
}

/// The device `device` stands for here, and a line saying what it is: `cpu`; for `cuda` the
/// GPU's name and the driver's CUDA version (`cuda: NVIDIA H200, driver CUDA 13.0`); for
/// `auto` that, or `cpu` with the reason no GPU can be used.
///
/// # Errors
/// `cuda` in a binary without the feature, or without a GPU, its driver, NVRTC or cuDNN.
pub fn resolve(device: Device) -> anyhow::Result<(Device, String)> {
    match device {
        Device::Cpu => Ok((Device::Cpu, "cpu".into())),
        Device::Cuda => cuda::describe().map(|d| (Device::Cuda, d)),
        Device::Auto => Ok(match cuda::describe() {
            Ok(d) => (Device::Cuda, d),
            Err(e) => (Device::Cpu, format!("cpu (auto: {e:#})")),
        }),
    }
}

/// The CUDA route: a driver check before burn touches CUDA (cudarc panics without one).
#[cfg(feature = "cuda")]
mod cuda {
    use super::*;

    /// The first GPU's name and the driver's CUDA version.
    pub(super) fn describe() -> anyhow::Result<String> {
        super::super::gpu::available()?;
        let name = std::panic::catch_unwind(|| -> anyhow::Result<String> {
            let ctx = cudarc::driver::CudaContext::new(0)?;
            let mut version = 0;
            // SAFETY: the driver writes its version into `version`.
            unsafe { cudarc::driver::sys::cuDriverGetVersion(&mut version) }.result()?;
            Ok(format!(
                "cuda: {}, driver CUDA {}.{}",
                ctx.name()?,
                version / 1000,
                version % 1000 / 10
            ))
        })
        .unwrap_or_else(|p| {
            Err(anyhow::anyhow!(
                "the CUDA driver failed: {}",
                panic_text(&*p)
            ))
        })?;
        Ok(name)
    }

    pub(super) fn train(
        cfg: &NetConfig,
        opts: &TrainingOptions,
        train_set: &Labelled,
        validation: &Labelled,
        seed: u64,
    ) -> anyhow::Result<Trained> {
        super::super::gpu::driver()?;
        // The cuDNN route (SGDM; `ISAR_CLUTTER_CUDA_ROUTE=burn` for burn's CUDA backend, kept
        // for Adam and for comparison).
        let burn_route = std::env::var("ISAR_CLUTTER_CUDA_ROUTE").as_deref() == Ok("burn");
        if opts.optimizer == Optimiser::Sgdm && !burn_route {
            let gpu = super::super::gpu::GpuOptions {
                graph: std::env::var("ISAR_CLUTTER_CUDA_GRAPH").as_deref() != Ok("0"),
                tf32: std::env::var("ISAR_CLUTTER_CUDA_TF32").as_deref() == Ok("1"),
                find: std::env::var("ISAR_CLUTTER_CUDA_FIND").as_deref() == Ok("1"),
            };
            return std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                super::super::gpu::train(cfg, opts, train_set, validation, seed, gpu)
            }))
            .unwrap_or_else(|p| {
                Err(anyhow::anyhow!(
                    "the cuDNN route failed: {}",
                    panic_text(&*p)
                ))
            });
        }
        type Gpu = burn::backend::Autodiff<burn::backend::Cuda>;
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            train_on::<Gpu>(cfg, opts, train_set, validation, seed, &Default::default())
        }))
        .map_err(|p| anyhow::anyhow!("the CUDA backend failed: {}", panic_text(&*p)))
    }

    /// A panic's message.
    fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
        p.downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default()
    }
}

/// Without the `cuda` feature: a clear error.
#[cfg(not(feature = "cuda"))]
mod cuda {
    use super::*;

    pub(super) fn describe() -> anyhow::Result<String> {
        anyhow::bail!("this binary was built without CUDA (`make build FEATURES='mat73 cuda'`)")
    }

    pub(super) fn train(
        _: &NetConfig,
        _: &TrainingOptions,
        _: &Labelled,
        _: &Labelled,
        _: u64,
    ) -> anyhow::Result<Trained> {
        anyhow::bail!(
            "training.device is cuda, but this binary was built without CUDA: rebuild with `make build FEATURES='mat73 cuda'`"
        )
    }
}
