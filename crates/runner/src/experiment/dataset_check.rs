//! Validation of one dataset entry into its typed kind: the fields its kind takes, ranges,
//! files (shapes read from their headers), presets and the measurement grid.

use super::*;

impl DatasetSpec {
    /// Fields this dataset's kind (and family) takes besides `id` and `kind`.
    pub fn fields(&self) -> &'static [&'static str] {
        const NOISE: [&str; 8] = [
            "family",
            "size",
            "samples",
            "half_width",
            "mean",
            "mean_im",
            "std",
            "texture_shape",
        ];
        const EXP: [&str; 10] = [
            "alpha_h", "alpha_v", NOISE[0], NOISE[1], NOISE[2], NOISE[3], NOISE[4], NOISE[5],
            NOISE[6], NOISE[7],
        ];
        const DYADIC: [&str; 10] = [
            "r_h", "r_v", NOISE[0], NOISE[1], NOISE[2], NOISE[3], NOISE[4], NOISE[5], NOISE[6],
            NOISE[7],
        ];
        match (self.kind, self.family) {
            (DatasetKind::Npy, _) => &["path", "layout"],
            (DatasetKind::Mat, _) => &["path", "variable", "layout"],
            (DatasetKind::Raw, _) => &["path", "samples", "size", "layout"],
            (DatasetKind::Netcdf, _) => &["path", "u", "v", "remove_monthly_mean"],
            (DatasetKind::Kspace, _) => &["path", "freqs", "azimuths_deg", "image_size"],
            (DatasetKind::VegetationIsar, _) => &[
                "plant",
                "wind",
                "samples",
                "scene",
                "measurement",
                "image_size",
                "save_kspace",
                "calibration",
            ],
            (DatasetKind::FilteredNoise, Some(Family::Dyadic)) => &DYADIC,
            (DatasetKind::FilteredNoise, _) => &EXP,
        }
    }

    /// Validates one dataset (`at` is its YAML path, e.g. `datasets[0]`).
    pub fn check(&self, ctx: &Ctx, at: &str, levels: usize) -> Result<Dataset, SpecError> {
        if self.id.is_empty()
            || !self
                .id
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "_-".contains(c))
        {
            return Err(ctx.err(
                format!("{at}.id"),
                format!(
                    "dataset id {:?} must be non-empty ASCII letters, digits, `_` or `-`",
                    self.id
                ),
            ));
        }
        let fields = [
            ("family", self.family.is_some()),
            ("alpha_h", self.alpha_h.is_some()),
            ("alpha_v", self.alpha_v.is_some()),
            ("r_h", self.r_h.is_some()),
            ("r_v", self.r_v.is_some()),
            ("size", self.size.is_some()),
            ("samples", self.samples.is_some()),
            ("half_width", self.half_width.is_some()),
            ("mean", self.mean.is_some()),
            ("mean_im", self.mean_im.is_some()),
            ("std", self.std.is_some()),
            ("texture_shape", self.texture_shape.is_some()),
            ("path", self.path.is_some()),
            ("layout", self.layout.is_some()),
            ("variable", self.variable.is_some()),
            ("plant", self.plant.is_some()),
            ("wind", self.wind.is_some()),
            ("scene", self.scene.is_some()),
            ("measurement", self.measurement.is_some()),
            ("image_size", self.image_size.is_some()),
            ("freqs", self.freqs.is_some()),
            ("save_kspace", self.save_kspace.is_some()),
            ("calibration", self.calibration.is_some()),
            ("azimuths_deg", self.azimuths_deg.is_some()),
            ("u", self.u.is_some()),
            ("v", self.v.is_some()),
            ("remove_monthly_mean", self.remove_monthly_mean.is_some()),
        ];
        let allowed = self.fields();
        if let Some((f, _)) = fields.iter().find(|(f, set)| *set && !allowed.contains(f)) {
            return Err(ctx.err(
                format!("{at}.{f}"),
                format!(
                    "`{f}` does not apply to this dataset (kind {}{}); it takes: {}",
                    yaml_name(&self.kind),
                    self.family
                        .map(|f| format!(", family {}", yaml_name(&f)))
                        .unwrap_or_default(),
                    allowed.join(", ")
                ),
            ));
        }
        let dataset = match self.kind {
            DatasetKind::Npy => Dataset::Npy(self.check_npy(ctx, at)?),
            DatasetKind::Mat => Dataset::Mat(self.check_mat(ctx, at)?),
            DatasetKind::Raw => Dataset::Raw(self.check_raw(ctx, at)?),
            DatasetKind::Netcdf => Dataset::Netcdf(self.check_netcdf(ctx, at)?),
            DatasetKind::Kspace => Dataset::Kspace(Box::new(self.check_kspace(ctx, at)?)),
            DatasetKind::VegetationIsar => {
                Dataset::Vegetation(Box::new(self.check_vegetation(ctx, at)?))
            }
            DatasetKind::FilteredNoise => {
                Dataset::FilteredNoise(Box::new(self.check_noise(ctx, at)?))
            }
        };
        let (n, h, w) = dataset.shape();
        if n < 2 {
            let field = match self.kind {
                DatasetKind::Npy => "path",
                DatasetKind::Mat => "variable",
                DatasetKind::FilteredNoise
                | DatasetKind::Raw
                | DatasetKind::Netcdf
                | DatasetKind::Kspace
                | DatasetKind::VegetationIsar => "samples",
            };
            return Err(ctx.err(
                format!("{at}.{field}"),
                format!("the stack has {n} sample(s); at least 2 are needed"),
            ));
        }
        check_levels(levels, h, w)
            .map_err(|e| ctx.err("analysis.levels", format!("dataset {}: {e}", self.id)))?;
        Ok(dataset)
    }

    fn check_kspace(&self, ctx: &Ctx, at: &str) -> Result<KspaceDataset, SpecError> {
        let rel = self
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind kspace needs `path`"))?;
        let path = ctx.resolve(rel);
        let header =
            npy::read_header(&path).map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        let [n, nf, nphi] = header.shape[..] else {
            return Err(ctx.err(
                format!("{at}.path"),
                format!(
                    "{} has shape {:?}; k-space data are [N, n_f, n_phi]",
                    path.display(),
                    header.shape
                ),
            ));
        };
        let vector = |v: &Option<Vector>, name: &str, len: usize| -> Result<Vec<f64>, SpecError> {
            let at = format!("{at}.{name}");
            let values = match v {
                None => return Err(ctx.err(&at, format!("kind kspace needs `{name}`"))),
                Some(Vector::List(l)) => l.clone(),
                Some(Vector::File(f)) => {
                    // Names the file, and the shape where it is not 1-D.
                    let f = ctx.resolve(f);
                    let m = npy::read_real_vector(&f).map_err(|e| ctx.err(&at, e.to_string()))?;
                    m.iter().copied().collect()
                }
            };
            if values.len() != len {
                return Err(ctx.err(
                    &at,
                    format!(
                        "{} values; the data have {len} along this axis",
                        values.len()
                    ),
                ));
            }
            Ok(values)
        };
        let freqs = vector(&self.freqs, "freqs", nf)?;
        let azimuths = vector(&self.azimuths_deg, "azimuths_deg", nphi)?
            .iter()
            .map(|d| d.to_radians())
            .collect();
        let measurement = crate::physics::isar::Measurement { freqs, azimuths };
        measurement.validate().map_err(|e| {
            let field = match &e {
                crate::physics::isar::IsarError::InvalidParameter {
                    name: "azimuths", ..
                } => "azimuths_deg",
                _ => "freqs",
            };
            ctx.err(format!("{at}.{field}"), e.to_string())
        })?;
        let image_size = self.image_size.unwrap_or(64);
        if image_size < 2 {
            return Err(ctx.err(format!("{at}.image_size"), "image_size must be at least 2"));
        }
        Ok(KspaceDataset {
            path,
            header,
            measurement,
            image_size,
            samples: n,
        })
    }

    fn check_vegetation(&self, ctx: &Ctx, at: &str) -> Result<VegetationDataset, SpecError> {
        use crate::physics::vegetation::SceneParams;
        let plant = self.plant.clone().ok_or_else(|| {
            ctx.err(
                format!("{at}.plant"),
                "kind vegetation_isar needs `plant` (A, B, C, D or E)",
            )
        })?;
        let wind = self.wind.clone().unwrap_or_else(|| "none".into());
        let preset = SceneParams::preset(&plant, &wind).ok_or_else(|| {
            let (field, what) = if crate::physics::vegetation::PlantParams::preset(&plant).is_none()
            {
                (
                    "plant",
                    format!("unknown plant {plant:?}; presets: A, B, C, D, E"),
                )
            } else {
                (
                    "wind",
                    format!("unknown wind {wind:?}; presets: none, light, medium"),
                )
            };
            ctx.err(format!("{at}.{field}"), what)
        })?;
        let scene = match &self.scene {
            None => preset,
            Some(over) => {
                let mut base = serde_yaml_ng::to_value(&preset).expect("scene serialises");
                merge(&mut base, over);
                let s: SceneParams = serde_path_to_error::deserialize(base).map_err(|e| {
                    let path = e.path().to_string();
                    let at = match path.as_str() {
                        "." => format!("{at}.scene"),
                        p => format!("{at}.scene.{p}"),
                    };
                    ctx.err(at, e.inner().to_string())
                })?;
                s
            }
        };
        // Each parameter's error at its own path (`scene.plant.n_stems`).
        let located = |part: &str, e: crate::physics::vegetation::VegError| match e {
            crate::physics::vegetation::VegError::InvalidParameter { name, .. } => {
                ctx.err(format!("{at}.scene.{part}{name}"), e.to_string())
            }
            _ => ctx.err(format!("{at}.scene"), e.to_string()),
        };
        scene.plant.validate().map_err(|e| located("plant.", e))?;
        scene.wind.validate().map_err(|e| located("wind.", e))?;
        scene.validate().map_err(|e| located("", e))?;
        let mut measurement = self.measurement.clone().unwrap_or_default();
        if let Some(c) = &self.calibration {
            c.check()
                .map_err(|(field, msg)| ctx.err(format!("{at}.calibration.{field}"), msg))?;
            measurement.f_start = c.f_start;
            measurement.f_stop = c.f_stop;
            measurement.frequencies = c.points;
        }
        measurement
            .check()
            .map_err(|e| ctx.err(format!("{at}.measurement"), e.to_string()))?;
        let samples = self.samples.ok_or_else(|| {
            ctx.err(
                format!("{at}.samples"),
                "kind vegetation_isar needs `samples`",
            )
        })?;
        let image_size = self.image_size.unwrap_or(64);
        if image_size < 2 {
            return Err(ctx.err(format!("{at}.image_size"), "image_size must be at least 2"));
        }
        Ok(VegetationDataset {
            plant,
            wind,
            scene,
            measurement,
            image_size,
            samples,
            save_kspace: self.save_kspace.unwrap_or(false),
            calibration: self.calibration.clone(),
        })
    }

    fn check_netcdf(&self, ctx: &Ctx, at: &str) -> Result<NetcdfDataset, SpecError> {
        let rel = self
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind netcdf needs `path`"))?;
        let path = ctx.resolve(rel);
        let file = crate::io::netcdf::NcFile::open(&path)
            .map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        let u = self
            .u
            .clone()
            .ok_or_else(|| ctx.err(format!("{at}.u"), "kind netcdf needs `u` (a variable name)"))?;
        let names: Vec<&str> = file.variables().iter().map(|v| v.name.as_str()).collect();
        let shape_of = |name: &str, field: &str| -> Result<(usize, usize, usize), SpecError> {
            let var = file.variable(name).ok_or_else(|| {
                ctx.err(
                    format!("{at}.{field}"),
                    format!(
                        "{} has no variable {name:?} (it has: {})",
                        path.display(),
                        names.join(", ")
                    ),
                )
            })?;
            match file.shape(var)[..] {
                [n, h, w] => Ok((n, h, w)),
                ref s => Err(ctx.err(
                    format!("{at}.{field}"),
                    format!("variable {name:?} has shape {s:?}; a stack is 3-D [time, rows, cols]"),
                )),
            }
        };
        let shape = shape_of(&u, "u")?;
        if let Some(v) = &self.v {
            let sv = shape_of(v, "v")?;
            if sv != shape {
                return Err(ctx.err(
                    format!("{at}.v"),
                    format!("{v:?} has shape {sv:?}, {u:?} has {shape:?}; they must match"),
                ));
            }
        }
        let remove_monthly_mean = self.remove_monthly_mean.unwrap_or(false);
        if remove_monthly_mean {
            crate::io::netcdf::time::months(&file, &u)
                .map_err(|e| ctx.err(format!("{at}.remove_monthly_mean"), e))?;
        }
        Ok(NetcdfDataset {
            path,
            u,
            v: self.v.clone(),
            remove_monthly_mean,
            shape,
        })
    }

    fn check_npy(&self, ctx: &Ctx, at: &str) -> Result<NpyDataset, SpecError> {
        let rel = self
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind npy needs `path`"))?;
        let path = ctx.resolve(rel);
        let header =
            npy::read_header(&path).map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        if header.shape.len() != 3 {
            return Err(ctx.err(
                format!("{at}.path"),
                format!(
                    "{} has shape {:?}; a stack is 3-D ([N, H, W], or [H, W, N] with layout: hwn)",
                    path.display(),
                    header.shape
                ),
            ));
        }
        Ok(NpyDataset {
            path,
            layout: self.layout.unwrap_or_default(),
            header,
        })
    }

    /// Checks a raw complex64 file: its size is `samples x size` values of 8 bytes.
    fn check_raw(&self, ctx: &Ctx, at: &str) -> Result<RawDataset, SpecError> {
        let need = |key: &str| ctx.err(format!("{at}.{key}"), format!("kind raw needs `{key}`"));
        let rel = self.path.as_ref().ok_or_else(|| need("path"))?;
        let n = self.samples.ok_or_else(|| need("samples"))?;
        let [h, w] = self.size.ok_or_else(|| need("size"))?;
        let path = ctx.resolve(rel);
        let bytes = std::fs::metadata(&path)
            .map_err(|e| ctx.err(format!("{at}.path"), format!("{}: {e}", path.display())))?
            .len();
        let want = [n, h, w, 8]
            .iter()
            .try_fold(1u64, |a, &b| a.checked_mul(b as u64));
        if want != Some(bytes) {
            return Err(ctx.err(
                format!("{at}.path"),
                format!(
                    "{} holds {bytes} bytes; {n} samples of {h} x {w} complex64 values are {} \
                     bytes (check samples and size)",
                    path.display(),
                    want.map_or("more than 2^64".into(), |b| b.to_string())
                ),
            ));
        }
        let layout = self.layout.unwrap_or_default();
        Ok(RawDataset {
            path,
            layout,
            shape: (n, h, w),
        })
    }

    /// Opens the `.mat` file and checks the variable (named, or the only numeric 3-D array)
    /// from the variables' headers, without reading the data.
    fn check_mat(&self, ctx: &Ctx, at: &str) -> Result<MatDataset, SpecError> {
        use crate::io::mat::{MatError, MatFile};
        let rel = self
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind mat needs `path`"))?;
        let path = ctx.resolve(rel);
        let file =
            MatFile::open(&path).map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        let v = file.stack_variable(self.variable.as_deref()).map_err(|e| {
            let field = match e {
                MatError::Missing { .. }
                | MatError::Ambiguous { .. }
                | MatError::NotStack { .. } => "variable",
                _ => "path",
            };
            ctx.err(format!("{at}.{field}"), e.to_string())
        })?;
        Ok(MatDataset {
            path,
            variable: v.name.clone(),
            layout: self.layout.unwrap_or(Layout::Hwn),
            dims: [v.dims[0], v.dims[1], v.dims[2]],
            class: v.class,
            complex: v.complex,
        })
    }

    /// Checks a filtered-noise dataset's fields into its typed parameters.
    ///
    /// Long because every family (exponential, dyadic, patterned maps) has its own fields, each
    /// checked with its YAML path.
    fn check_noise(&self, ctx: &Ctx, at: &str) -> Result<FilteredNoise, SpecError> {
        let family = self.family.ok_or_else(|| {
            ctx.err(
                format!("{at}.family"),
                "kind filtered_noise needs `family` (exponential or dyadic)",
            )
        })?;
        let [h, w] = self.size.ok_or_else(|| {
            ctx.err(
                format!("{at}.size"),
                "kind filtered_noise needs `size: [H, W]`",
            )
        })?;
        if h == 0 || w == 0 {
            return Err(ctx.err(
                format!("{at}.size"),
                format!("size must be positive, got [{h}, {w}]"),
            ));
        }
        let samples = self.samples.ok_or_else(|| {
            ctx.err(
                format!("{at}.samples"),
                "kind filtered_noise needs `samples`",
            )
        })?;
        let half_width = self.half_width.unwrap_or(8);
        let map = |p: &Option<ParamMap>, name: &str, default: f64| -> Result<Map, SpecError> {
            match p {
                Some(p) => p.check(ctx, &format!("{at}.{name}"), h, w),
                None => Ok(Map::Constant(default)),
            }
        };
        let filter = match family {
            Family::Exponential => {
                let need = |p: &Option<ParamMap>, name: &str| -> Result<Map, SpecError> {
                    let p = p.as_ref().ok_or_else(|| {
                        ctx.err(
                            format!("{at}.{name}"),
                            format!("family exponential needs `{name}`"),
                        )
                    })?;
                    let m = p.check(ctx, &format!("{at}.{name}"), h, w)?;
                    check_range(
                        ctx,
                        &format!("{at}.{name}"),
                        &m,
                        |v| v != 0.0 && !v.is_nan(),
                        "alpha must be non-zero (negative alpha: sign-alternating filter)",
                    )?;
                    Ok(m)
                };
                FilterParams::Exponential {
                    alpha_h: need(&self.alpha_h, "alpha_h")?,
                    alpha_v: need(&self.alpha_v, "alpha_v")?,
                }
            }
            Family::Dyadic => {
                let list = |p: &Option<Vec<ParamMap>>, name: &str| -> Result<Vec<Map>, SpecError> {
                    let p = p.as_ref().ok_or_else(|| {
                        ctx.err(
                            format!("{at}.{name}"),
                            format!("family dyadic needs `{name}: [r_1, ..., r_L]`"),
                        )
                    })?;
                    if p.is_empty() {
                        return Err(ctx.err(format!("{at}.{name}"), "needs at least one parameter"));
                    }
                    let reach = crate::stats::filters::dyadic_reach(p.len());
                    if half_width < reach {
                        return Err(ctx.err(format!("{at}.half_width"), format!("a {}-level dyadic filter reaches offset {reach}; half_width {half_width} would truncate it", p.len())));
                    }
                    p.iter()
                        .enumerate()
                        .map(|(i, m)| {
                            let m = m.check(ctx, &format!("{at}.{name}[{i}]"), h, w)?;
                            check_range(
                                ctx,
                                &format!("{at}.{name}[{i}]"),
                                &m,
                                f64::is_finite,
                                "r must be finite",
                            )?;
                            Ok(m)
                        })
                        .collect()
                };
                let (r_h, r_v) = (list(&self.r_h, "r_h")?, list(&self.r_v, "r_v")?);
                if r_h.len() != r_v.len() {
                    return Err(ctx.err(
                        format!("{at}.r_v"),
                        format!(
                            "r_h has {} parameters, r_v {}; they must match",
                            r_h.len(),
                            r_v.len()
                        ),
                    ));
                }
                FilterParams::Dyadic { r_h, r_v }
            }
        };
        let std = map(&self.std, "std", 1.0)?;
        check_range(
            ctx,
            &format!("{at}.std"),
            &std,
            |v| v >= 0.0 && v.is_finite(),
            "std must be finite and >= 0",
        )?;
        let texture_shape = self.texture_shape;
        if let Some(nu) = texture_shape {
            if !(nu > 0.0 && nu.is_finite()) {
                return Err(ctx.err(
                    format!("{at}.texture_shape"),
                    format!("texture_shape {nu} must be finite and > 0"),
                ));
            }
        }
        let finite = |p: &Option<ParamMap>, name: &str| -> Result<Map, SpecError> {
            let m = map(p, name, 0.0)?;
            check_range(
                ctx,
                &format!("{at}.{name}"),
                &m,
                f64::is_finite,
                &format!("{name} must be finite"),
            )?;
            Ok(m)
        };
        Ok(FilteredNoise {
            filter,
            height: h,
            width: w,
            samples,
            half_width,
            mean: finite(&self.mean, "mean")?,
            mean_im: finite(&self.mean_im, "mean_im")?,
            std,
            texture_shape,
        })
    }
}
