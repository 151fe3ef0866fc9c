//! One convolution block of the cuDNN route's passes (convolution, batch normalisation, ReLU,
//! pooling; their gradients), as methods of [`super::DeviceNet`] on a [`super::Pass`].

use super::super::dnn::{ck, cptr, mptr, s, ONE, ZERO};
use super::super::kernels::{blocks, grid, launch};
use super::{at, DeviceNet, Pass};
use crate::apps::cnn::net::BN_EPSILON;
use anyhow::{Context, Result};
use cudarc::cudnn::sys;
use cudarc::driver::PushKernelArg;

impl DeviceNet {
    /// Block `b` of the forward pass from `input`; gives the address of its output.
    pub(super) fn forward_block(
        &self,
        pass: &Pass,
        b: usize,
        mut input: u64,
        train: bool,
    ) -> Result<u64> {
        let (st, h) = (&self.stream, &self.handle);
        let (ws, ws_len) = (self.workspace.ptr, self.workspace.len);
        let bp = &pass.blocks[b];
        let g = bp.g;
        let [w, bias, _, _] = self.p.block[b].map(|o| at(&self.params, o));
        if let Some(padded) = &bp.padded {
            let planes = (pass.n * g.c) as u32;
            let (hp, wp) = g.padded_hw();
            launch!(
                st,
                self.k.pad,
                grid(padded.len),
                input,
                padded.ptr,
                planes,
                g.h as u32,
                g.w as u32,
                hp as u32,
                wp as u32,
                g.top as u32,
                g.left as u32
            )?;
            input = padded.ptr;
        }
        let yd = bp.conv.y.0;
        // SAFETY: every address is a buffer of the descriptor's shape (allocated in
        // `BlockPass::new` for this pass's `n`, or the parameter buffer's offsets).
        unsafe {
            bp.conv
                .forward(h, input, w, bias, bp.conv_out.ptr, ws, ws_len)?;
        }
        self.normalise(pass, b, train)?;
        // SAFETY: as above.
        unsafe {
            ck(
                sys::cudnnActivationForward(
                    h.0,
                    self.relu.0,
                    s(&ONE),
                    yd,
                    cptr(bp.bn_out.ptr),
                    s(&ZERO),
                    yd,
                    mptr(bp.relu_out.ptr),
                ),
                "cudnnActivationForward",
            )?;
            if let (Some(pd), Some(po)) = (&bp.pooled, &bp.pool_out) {
                ck(
                    sys::cudnnPoolingForward(
                        h.0,
                        self.pool.0,
                        s(&ONE),
                        yd,
                        cptr(bp.relu_out.ptr),
                        s(&ZERO),
                        pd.0,
                        mptr(po.ptr),
                    ),
                    "cudnnPoolingForward",
                )?;
            }
        }
        Ok(bp.output())
    }

    /// Block `b`'s batch normalisation: with the batch's statistics when `train` (and the
    /// running ones updated), else with the running ones.
    fn normalise(&self, pass: &Pass, b: usize, train: bool) -> Result<()> {
        let (st, h) = (&self.stream, &self.handle);
        let bp = &pass.blocks[b];
        let g = bp.g;
        let [_, _, gamma, beta] = self.p.block[b].map(|o| at(&self.params, o));
        let yd = bp.conv.y.0;
        // SAFETY: buffers of the descriptors' shapes (allocated in `BlockPass::new` for this
        // pass's `n`, or the parameter buffer's offsets).
        unsafe {
            if train {
                ck(
                    sys::cudnnBatchNormalizationForwardTraining(
                        h.0,
                        sys::cudnnBatchNormMode_t::CUDNN_BATCHNORM_SPATIAL,
                        s(&ONE),
                        s(&ZERO),
                        yd,
                        cptr(bp.conv_out.ptr),
                        yd,
                        mptr(bp.bn_out.ptr),
                        bp.conv.bias.0,
                        cptr(gamma),
                        cptr(beta),
                        0.0,
                        std::ptr::null_mut(),
                        std::ptr::null_mut(),
                        BN_EPSILON,
                        mptr(bp.saved_mean.ptr),
                        mptr(bp.saved_inv.ptr),
                    ),
                    "cudnnBatchNormalizationForwardTraining",
                )?;
            } else {
                let [rm, rv] = self.p.running[b].map(|o| at(&self.running, o));
                ck(
                    sys::cudnnBatchNormalizationForwardInference(
                        h.0,
                        sys::cudnnBatchNormMode_t::CUDNN_BATCHNORM_SPATIAL,
                        s(&ONE),
                        s(&ZERO),
                        yd,
                        cptr(bp.conv_out.ptr),
                        yd,
                        mptr(bp.bn_out.ptr),
                        bp.conv.bias.0,
                        cptr(gamma),
                        cptr(beta),
                        cptr(rm),
                        cptr(rv),
                        BN_EPSILON,
                    ),
                    "cudnnBatchNormalizationForwardInference",
                )?;
            }
        }
        if let Some(partial) = &bp.partial {
            let [rm, rv] = self.p.running[b].map(|o| at(&self.running, o));
            let (n, f, hw, parts) = (
                pass.n as u32,
                g.f as u32,
                (g.oh * g.ow) as u32,
                bp.parts as u32,
            );
            let mut cfg = blocks(g.f);
            cfg.grid_dim.1 = parts;
            launch!(
                st,
                self.k.bn_partial,
                cfg,
                bp.conv_out.ptr,
                n,
                f,
                hw,
                parts,
                partial.ptr
            )?;
            launch!(
                st,
                self.k.bn_running,
                grid(g.f),
                partial.ptr,
                bp.conv_out.ptr,
                n,
                f,
                hw,
                parts,
                rm,
                rv,
                self.ctr.ptr
            )?;
        }
        Ok(())
    }

    /// Block `b`'s gradients (its weights, biases, BN scale and offset) from the gradient of
    /// its output, and the gradient of its input for the block before.
    pub(super) fn backward_block(&self, pass: &Pass, b: usize) -> Result<()> {
        let h = &self.handle;
        let (ws, ws_len) = (self.workspace.ptr, self.workspace.len);
        let bp = &pass.blocks[b];
        let yd = bp.conv.y.0;
        let (d_a, d_b) = (
            bp.d_a.as_ref().context("training")?.ptr,
            bp.d_b.as_ref().context("training")?.ptr,
        );
        let [w, _, gamma, _] = self.p.block[b].map(|o| at(&self.params, o));
        let [dw, db, dgamma, dbeta] = self.p.block[b].map(|o| at(&self.grads, o));
        let input = match (&bp.padded, b) {
            (Some(p), _) => p.ptr,
            (None, 0) => pass.x.as_ref().context("training")?.ptr,
            (None, _) => pass.blocks[b - 1].output(),
        };
        self.through_relu(pass, b)?;
        // SAFETY: as above.
        unsafe {
            ck(
                sys::cudnnBatchNormalizationBackward(
                    h.0,
                    sys::cudnnBatchNormMode_t::CUDNN_BATCHNORM_SPATIAL,
                    s(&ONE),
                    s(&ZERO),
                    s(&ONE),
                    s(&ZERO),
                    yd,
                    cptr(bp.conv_out.ptr),
                    yd,
                    cptr(d_b),
                    yd,
                    mptr(d_a),
                    bp.conv.bias.0,
                    cptr(gamma),
                    mptr(dgamma),
                    mptr(dbeta),
                    BN_EPSILON,
                    cptr(bp.saved_mean.ptr),
                    cptr(bp.saved_inv.ptr),
                ),
                "cudnnBatchNormalizationBackward",
            )?;
            bp.conv
                .backward_weights(h, input, d_a, dw, db, ws, ws_len)?;
        }
        if b > 0 {
            self.input_gradient(pass, b, w, d_a)?;
        }
        Ok(())
    }

    /// The gradient of block `b`'s input (the block before's output) from that of its
    /// convolution's output `d_a`, through the explicit padding where there is one.
    fn input_gradient(&self, pass: &Pass, b: usize, w: u64, d_a: u64) -> Result<()> {
        let (st, h) = (&self.stream, &self.handle);
        let (ws, ws_len) = (self.workspace.ptr, self.workspace.len);
        let bp = &pass.blocks[b];
        let g = bp.g;
        let d_prev = pass.blocks[b - 1].d_out.as_ref().context("training")?.ptr;
        match &bp.d_padded {
            Some(dp) => {
                // SAFETY: as above.
                unsafe { bp.conv.backward_data(h, w, d_a, dp.ptr, ws, ws_len)? };
                let planes = (pass.n * g.c) as u32;
                let (hp, wp) = g.padded_hw();
                let len = pass.n * g.c * g.h * g.w;
                launch!(
                    st,
                    self.k.crop,
                    grid(len),
                    dp.ptr,
                    d_prev,
                    planes,
                    g.h as u32,
                    g.w as u32,
                    hp as u32,
                    wp as u32,
                    g.top as u32,
                    g.left as u32
                )?;
            }
            // SAFETY: as above.
            None => unsafe { bp.conv.backward_data(h, w, d_a, d_prev, ws, ws_len)? },
        }
        Ok(())
    }

    /// The gradient of block `b`'s batch normalisation output (into `d_b`) from that of the
    /// block's output, back through the pooling (if any) and the ReLU.
    fn through_relu(&self, pass: &Pass, b: usize) -> Result<()> {
        let h = &self.handle;
        let bp = &pass.blocks[b];
        let yd = bp.conv.y.0;
        let (d_a, d_b, d_out) = (
            bp.d_a.as_ref().context("training")?.ptr,
            bp.d_b.as_ref().context("training")?.ptr,
            bp.d_out.as_ref().context("training")?.ptr,
        );
        // SAFETY: buffers of the descriptors' shapes (allocated in `BlockPass::new`).
        unsafe {
            let d_relu = match (&bp.pooled, &bp.pool_out) {
                (Some(pd), Some(po)) => {
                    ck(
                        sys::cudnnPoolingBackward(
                            h.0,
                            self.pool.0,
                            s(&ONE),
                            pd.0,
                            cptr(po.ptr),
                            pd.0,
                            cptr(d_out),
                            yd,
                            cptr(bp.relu_out.ptr),
                            s(&ZERO),
                            yd,
                            mptr(d_a),
                        ),
                        "cudnnPoolingBackward",
                    )?;
                    d_a
                }
                _ => d_out,
            };
            ck(
                sys::cudnnActivationBackward(
                    h.0,
                    self.relu.0,
                    s(&ONE),
                    yd,
                    cptr(bp.relu_out.ptr),
                    yd,
                    cptr(d_relu),
                    yd,
                    cptr(bp.bn_out.ptr),
                    s(&ZERO),
                    yd,
                    mptr(d_b),
                ),
                "cudnnActivationBackward",
            )?;
        }
        Ok(())
    }
}
