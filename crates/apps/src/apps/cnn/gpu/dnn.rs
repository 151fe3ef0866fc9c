//! Owners of cuDNN's handle and descriptors for the cuDNN route (NCHW, `float`): tensors,
//! filters, a convolution with the algorithms chosen for it once (cuDNN's heuristics, the
//! deterministic algorithms only, so that a training is a function of its seed on a given GPU
//! and library), 2x2 max pooling and ReLU. Each owner destroys its descriptor when dropped.

use anyhow::{bail, Result};
use cudarc::cudnn::sys;
use std::ffi::c_void;

/// `Ok` for cuDNN's success, otherwise an error naming the call.
pub(super) fn ck(status: sys::cudnnStatus_t, what: &str) -> Result<()> {
    if status == sys::cudnnStatus_t::CUDNN_STATUS_SUCCESS {
        Ok(())
    } else {
        bail!("cuDNN {what} failed: {status:?}")
    }
}

/// A device address as cuDNN's input pointer.
pub(super) fn cptr(p: u64) -> *const c_void {
    p as usize as *const c_void
}

/// A device address as cuDNN's output pointer.
pub(super) fn mptr(p: u64) -> *mut c_void {
    p as usize as *mut c_void
}

/// The scalars cuDNN's blending takes by address.
pub(super) const ONE: f32 = 1.0;
/// See [`ONE`].
pub(super) const ZERO: f32 = 0.0;

/// `&ONE` / `&ZERO` as cuDNN's `const void*`.
pub(super) fn s(v: &'static f32) -> *const c_void {
    v as *const f32 as *const c_void
}

/// A cuDNN handle bound to a stream.
pub(super) struct Handle(pub sys::cudnnHandle_t);

impl Handle {
    /// A handle issuing its work on `stream` (a `CUstream`).
    pub fn new(stream: *mut c_void) -> Result<Self> {
        let mut h = std::ptr::null_mut();
        // SAFETY: cuDNN writes a new handle into `h`.
        ck(unsafe { sys::cudnnCreate(&mut h) }, "cudnnCreate")?;
        let handle = Handle(h);
        // SAFETY: a live handle and a live stream of the same context.
        ck(
            unsafe { sys::cudnnSetStream(handle.0, stream as _) },
            "cudnnSetStream",
        )?;
        Ok(handle)
    }
}

impl Drop for Handle {
    fn drop(&mut self) {
        // SAFETY: the handle was created by cudnnCreate and is dropped once.
        unsafe { sys::cudnnDestroy(self.0) };
    }
}

/// A 4-d NCHW float tensor descriptor.
pub(super) struct Tensor(pub sys::cudnnTensorDescriptor_t);

impl Tensor {
    /// `[n, c, h, w]`.
    pub fn new(n: usize, c: usize, h: usize, w: usize) -> Result<Self> {
        let mut d = std::ptr::null_mut();
        // SAFETY: cuDNN writes a new descriptor into `d`.
        ck(
            unsafe { sys::cudnnCreateTensorDescriptor(&mut d) },
            "cudnnCreateTensorDescriptor",
        )?;
        let t = Tensor(d);
        // SAFETY: a live descriptor.
        ck(
            unsafe {
                sys::cudnnSetTensor4dDescriptor(
                    t.0,
                    sys::cudnnTensorFormat_t::CUDNN_TENSOR_NCHW,
                    sys::cudnnDataType_t::CUDNN_DATA_FLOAT,
                    n as i32,
                    c as i32,
                    h as i32,
                    w as i32,
                )
            },
            "cudnnSetTensor4dDescriptor",
        )?;
        Ok(t)
    }
}

impl Drop for Tensor {
    fn drop(&mut self) {
        // SAFETY: created above, dropped once.
        unsafe { sys::cudnnDestroyTensorDescriptor(self.0) };
    }
}

/// A filter descriptor `[k, c, r, s]` (NCHW, float).
pub(super) struct Filter(pub sys::cudnnFilterDescriptor_t);

impl Filter {
    fn new(k: usize, c: usize, r: usize, s: usize) -> Result<Self> {
        let mut d = std::ptr::null_mut();
        // SAFETY: cuDNN writes a new descriptor into `d`.
        ck(
            unsafe { sys::cudnnCreateFilterDescriptor(&mut d) },
            "cudnnCreateFilterDescriptor",
        )?;
        let f = Filter(d);
        // SAFETY: a live descriptor.
        ck(
            unsafe {
                sys::cudnnSetFilter4dDescriptor(
                    f.0,
                    sys::cudnnDataType_t::CUDNN_DATA_FLOAT,
                    sys::cudnnTensorFormat_t::CUDNN_TENSOR_NCHW,
                    k as i32,
                    c as i32,
                    r as i32,
                    s as i32,
                )
            },
            "cudnnSetFilter4dDescriptor",
        )?;
        Ok(f)
    }
}

impl Drop for Filter {
    fn drop(&mut self) {
        // SAFETY: created above, dropped once.
        unsafe { sys::cudnnDestroyFilterDescriptor(self.0) };
    }
}

/// A convolution `[n, c, h, w] * [k, c, r, s] -> [n, k, oh, ow]` (stride, symmetric padding)
/// with its algorithms and their workspace.
pub(super) struct Conv {
    desc: sys::cudnnConvolutionDescriptor_t,
    /// Input.
    pub x: Tensor,
    /// Weights.
    pub w: Filter,
    /// Output.
    pub y: Tensor,
    /// `[1, K, 1, 1]`: the biases (and a following batch normalisation's scale and offset).
    pub bias: Tensor,
    fwd: sys::cudnnConvolutionFwdAlgo_t,
    bwd_data: sys::cudnnConvolutionBwdDataAlgo_t,
    bwd_filter: sys::cudnnConvolutionBwdFilterAlgo_t,
    /// Workspace bytes the three algorithms need at most.
    pub workspace: usize,
}

impl Drop for Conv {
    fn drop(&mut self) {
        // SAFETY: created in `new`, dropped once.
        unsafe { sys::cudnnDestroyConvolutionDescriptor(self.desc) };
    }
}

/// The geometry of a [`Conv`].
#[derive(Debug, Clone, Copy)]
pub(super) struct ConvShape {
    pub n: usize,
    pub c: usize,
    pub h: usize,
    pub w: usize,
    pub k: usize,
    pub r: usize,
    pub s: usize,
    pub stride: usize,
    pub pad_h: usize,
    pub pad_w: usize,
}

impl ConvShape {
    /// Output height and width.
    pub fn out(&self) -> (usize, usize) {
        (
            (self.h + 2 * self.pad_h - self.r) / self.stride + 1,
            (self.w + 2 * self.pad_w - self.s) / self.stride + 1,
        )
    }
}

/// Workspace cuDNN may take per algorithm (larger ones are skipped).
const WORKSPACE_LIMIT: usize = 256 << 20;

impl Conv {
    /// The convolution `g` with deterministic algorithms chosen by cuDNN's heuristics (or,
    /// with `find`, by timing them), in strict float arithmetic (`tf32: false`, FMA math) or
    /// with TF32 tensor cores allowed (float arithmetic for a shape with no deterministic TF32
    /// algorithm); the backward algorithms only for a training pass (`train`).
    pub fn new(handle: &Handle, g: ConvShape, tf32: bool, train: bool, find: bool) -> Result<Self> {
        let mut desc = std::ptr::null_mut();
        // SAFETY: cuDNN writes a new descriptor into `desc`.
        ck(
            unsafe { sys::cudnnCreateConvolutionDescriptor(&mut desc) },
            "cudnnCreateConvolutionDescriptor",
        )?;
        let (oh, ow) = g.out();
        let mut conv = Conv {
            desc,
            x: Tensor::new(g.n, g.c, g.h, g.w)?,
            w: Filter::new(g.k, g.c, g.r, g.s)?,
            y: Tensor::new(g.n, g.k, oh, ow)?,
            bias: Tensor::new(1, g.k, 1, 1)?,
            fwd: sys::cudnnConvolutionFwdAlgo_t::CUDNN_CONVOLUTION_FWD_ALGO_IMPLICIT_GEMM,
            bwd_data: sys::cudnnConvolutionBwdDataAlgo_t::CUDNN_CONVOLUTION_BWD_DATA_ALGO_1,
            bwd_filter: sys::cudnnConvolutionBwdFilterAlgo_t::CUDNN_CONVOLUTION_BWD_FILTER_ALGO_1,
            workspace: 0,
        };
        let math = if tf32 {
            sys::cudnnMathType_t::CUDNN_DEFAULT_MATH
        } else {
            sys::cudnnMathType_t::CUDNN_FMA_MATH
        };
        // SAFETY: a live descriptor.
        unsafe {
            ck(
                sys::cudnnSetConvolution2dDescriptor(
                    conv.desc,
                    g.pad_h as i32,
                    g.pad_w as i32,
                    g.stride as i32,
                    g.stride as i32,
                    1,
                    1,
                    sys::cudnnConvolutionMode_t::CUDNN_CROSS_CORRELATION,
                    sys::cudnnDataType_t::CUDNN_DATA_FLOAT,
                ),
                "cudnnSetConvolution2dDescriptor",
            )?;
            ck(
                sys::cudnnSetConvolutionMathType(conv.desc, math),
                "cudnnSetConvolutionMathType",
            )?;
        }
        // SAFETY: the descriptors are set; `choose`'s arrays hold as many entries as it asks for.
        let mut tf32 = tf32;
        if let Err(e) = unsafe { conv.choose(handle, g, train, find) } {
            if !tf32 {
                return Err(e);
            }
            // No deterministic TF32 algorithm for this shape: float arithmetic for it.
            tf32 = false;
            // SAFETY: as above.
            unsafe {
                ck(
                    sys::cudnnSetConvolutionMathType(
                        conv.desc,
                        sys::cudnnMathType_t::CUDNN_FMA_MATH,
                    ),
                    "cudnnSetConvolutionMathType",
                )?;
                conv.choose(handle, g, train, find)?;
            }
        }
        conv.report(g, tf32, train, find);
        Ok(conv)
    }

    /// Each direction's algorithm: the first deterministic one within the workspace limit of
    /// cuDNN's list, ranked by its heuristics (or by time with `find`); the backward ones only
    /// for a training pass.
    ///
    /// # Safety
    /// The descriptors are set ([`Conv::new`]).
    unsafe fn choose(
        &mut self,
        handle: &Handle,
        g: ConvShape,
        train: bool,
        find: bool,
    ) -> Result<()> {
        let conv = self;
        macro_rules! pick {
            ($get:ident, $find:ident, $perf:ty, $a:expr, $b:expr, $c:expr, $what:literal) => {{
                let mut got = 0;
                let mut perf: [$perf; 8] = std::mem::zeroed();
                let h = handle.0;
                if find {
                    ck(
                        sys::$find(h, $a, $b, conv.desc, $c, 8, &mut got, perf.as_mut_ptr()),
                        stringify!($find),
                    )?;
                } else {
                    ck(
                        sys::$get(h, $a, $b, conv.desc, $c, 8, &mut got, perf.as_mut_ptr()),
                        stringify!($get),
                    )?;
                }
                perf[..got as usize]
                    .iter()
                    .find(|p| {
                        p.status == sys::cudnnStatus_t::CUDNN_STATUS_SUCCESS
                            && p.determinism == sys::cudnnDeterminism_t::CUDNN_DETERMINISTIC
                            && p.memory <= WORKSPACE_LIMIT
                    })
                    .map(|p| (p.algo, p.memory))
                    .ok_or_else(|| {
                        anyhow::anyhow!(
                            "cuDNN offers no deterministic {} algorithm for {g:?}",
                            $what
                        )
                    })?
            }};
        }
        let (x, w, y) = (conv.x.0, conv.w.0, conv.y.0);
        let (algo, mem) = pick!(
            cudnnGetConvolutionForwardAlgorithm_v7,
            cudnnFindConvolutionForwardAlgorithm,
            sys::cudnnConvolutionFwdAlgoPerf_t,
            x,
            w,
            y,
            "forward"
        );
        conv.fwd = algo;
        conv.workspace = mem;
        if train {
            let (algo, mem) = pick!(
                cudnnGetConvolutionBackwardDataAlgorithm_v7,
                cudnnFindConvolutionBackwardDataAlgorithm,
                sys::cudnnConvolutionBwdDataAlgoPerf_t,
                w,
                y,
                x,
                "backward-data"
            );
            conv.bwd_data = algo;
            conv.workspace = conv.workspace.max(mem);
            let (algo, mem) = pick!(
                cudnnGetConvolutionBackwardFilterAlgorithm_v7,
                cudnnFindConvolutionBackwardFilterAlgorithm,
                sys::cudnnConvolutionBwdFilterAlgoPerf_t,
                x,
                y,
                w,
                "backward-filter"
            );
            conv.bwd_filter = algo;
            conv.workspace = conv.workspace.max(mem);
        }
        Ok(())
    }

    /// Prints the chosen algorithms under `ISAR_CLUTTER_CUDA_VERBOSE`, each choice once per process.
    fn report(&self, g: ConvShape, tf32: bool, train: bool, find: bool) {
        let conv = self;
        if std::env::var_os("ISAR_CLUTTER_CUDA_VERBOSE").is_some() {
            // Each choice once per process.
            static SEEN: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
            let line = format!(
                "cuDNN {g:?} (tf32 {tf32}, find {find}, train {train}): {:?}, {:?}, {:?}, workspace {} bytes",
                conv.fwd, conv.bwd_data, conv.bwd_filter, conv.workspace
            );
            let mut seen = SEEN.lock().unwrap_or_else(|e| e.into_inner());
            if !seen.contains(&line) {
                eprintln!("{line}");
                seen.push(line);
            }
        }
    }

    /// `y = conv(x, w) + b` (`b` per output channel).
    ///
    /// # Safety
    /// Device addresses of buffers of this convolution's shapes; `ws` of at least
    /// [`Conv::workspace`] bytes (`ws_len`).
    #[allow(clippy::too_many_arguments)]
    pub unsafe fn forward(
        &self,
        h: &Handle,
        x: u64,
        w: u64,
        b: u64,
        y: u64,
        ws: u64,
        ws_len: usize,
    ) -> Result<()> {
        ck(
            sys::cudnnConvolutionForward(
                h.0,
                s(&ONE),
                self.x.0,
                cptr(x),
                self.w.0,
                cptr(w),
                self.desc,
                self.fwd,
                mptr(ws),
                ws_len,
                s(&ZERO),
                self.y.0,
                mptr(y),
            ),
            "cudnnConvolutionForward",
        )?;
        ck(
            sys::cudnnAddTensor(
                h.0,
                s(&ONE),
                self.bias.0,
                cptr(b),
                s(&ONE),
                self.y.0,
                mptr(y),
            ),
            "cudnnAddTensor",
        )
    }

    /// `dx = conv_backward_data(w, dy)`.
    ///
    /// # Safety
    /// As [`Conv::forward`].
    pub unsafe fn backward_data(
        &self,
        h: &Handle,
        w: u64,
        dy: u64,
        dx: u64,
        ws: u64,
        ws_len: usize,
    ) -> Result<()> {
        ck(
            sys::cudnnConvolutionBackwardData(
                h.0,
                s(&ONE),
                self.w.0,
                cptr(w),
                self.y.0,
                cptr(dy),
                self.desc,
                self.bwd_data,
                mptr(ws),
                ws_len,
                s(&ZERO),
                self.x.0,
                mptr(dx),
            ),
            "cudnnConvolutionBackwardData",
        )
    }

    /// The weights' and biases' gradients `dw`, `db` from the input `x` and the output's
    /// gradient `dy`.
    ///
    /// # Safety
    /// As [`Conv::forward`].
    #[allow(clippy::too_many_arguments)]
    pub unsafe fn backward_weights(
        &self,
        h: &Handle,
        x: u64,
        dy: u64,
        dw: u64,
        db: u64,
        ws: u64,
        ws_len: usize,
    ) -> Result<()> {
        ck(
            sys::cudnnConvolutionBackwardBias(
                h.0,
                s(&ONE),
                self.y.0,
                cptr(dy),
                s(&ZERO),
                self.bias.0,
                mptr(db),
            ),
            "cudnnConvolutionBackwardBias",
        )?;
        ck(
            sys::cudnnConvolutionBackwardFilter(
                h.0,
                s(&ONE),
                self.x.0,
                cptr(x),
                self.y.0,
                cptr(dy),
                self.desc,
                self.bwd_filter,
                mptr(ws),
                ws_len,
                s(&ZERO),
                self.w.0,
                mptr(dw),
            ),
            "cudnnConvolutionBackwardFilter",
        )
    }
}

/// 2x2 max pooling, stride 2, no padding (deterministic gradient).
pub(super) struct Pool(pub sys::cudnnPoolingDescriptor_t);

impl Pool {
    /// The pooling of the networks.
    pub fn new() -> Result<Self> {
        let mut d = std::ptr::null_mut();
        // SAFETY: cuDNN writes a new descriptor into `d`, then sets it.
        unsafe {
            ck(
                sys::cudnnCreatePoolingDescriptor(&mut d),
                "cudnnCreatePoolingDescriptor",
            )?;
            let p = Pool(d);
            ck(
                sys::cudnnSetPooling2dDescriptor(
                    p.0,
                    sys::cudnnPoolingMode_t::CUDNN_POOLING_MAX_DETERMINISTIC,
                    sys::cudnnNanPropagation_t::CUDNN_NOT_PROPAGATE_NAN,
                    2,
                    2,
                    0,
                    0,
                    2,
                    2,
                ),
                "cudnnSetPooling2dDescriptor",
            )?;
            Ok(p)
        }
    }
}

impl Drop for Pool {
    fn drop(&mut self) {
        // SAFETY: created above, dropped once.
        unsafe { sys::cudnnDestroyPoolingDescriptor(self.0) };
    }
}

/// ReLU.
pub(super) struct Relu(pub sys::cudnnActivationDescriptor_t);

impl Relu {
    /// `max(x, 0)`.
    pub fn new() -> Result<Self> {
        let mut d = std::ptr::null_mut();
        // SAFETY: cuDNN writes a new descriptor into `d`, then sets it.
        unsafe {
            ck(
                sys::cudnnCreateActivationDescriptor(&mut d),
                "cudnnCreateActivationDescriptor",
            )?;
            let r = Relu(d);
            ck(
                sys::cudnnSetActivationDescriptor(
                    r.0,
                    sys::cudnnActivationMode_t::CUDNN_ACTIVATION_RELU,
                    sys::cudnnNanPropagation_t::CUDNN_NOT_PROPAGATE_NAN,
                    0.0,
                ),
                "cudnnSetActivationDescriptor",
            )?;
            Ok(r)
        }
    }
}

impl Drop for Relu {
    fn drop(&mut self) {
        // SAFETY: created above, dropped once.
        unsafe { sys::cudnnDestroyActivationDescriptor(self.0) };
    }
}
