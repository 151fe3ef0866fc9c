# isar-clutter: build, run experiments, test.
# The cargo target directory lives outside the checkout (a cold release build with polars
# takes 20+ minutes on 2 cores; later builds are incremental). Override CARGO_TARGET_DIR to move it.
CARGO_TARGET_DIR ?= $(HOME)/.cache/isar-clutter/target
export CARGO_TARGET_DIR
SPEC ?= experiments/table4_exponential.yaml
ARGS ?=
BIN := $(CARGO_TARGET_DIR)/release/isar-clutter
PYTHON ?= python3
VENV := .venv
# Cargo features: `mat73` reads and writes MATLAB v7.3 (HDF5) .mat files with the system's
# libhdf5 (Debian's libhdf5-dev, installed by the `hdf5` target). `make FEATURES=` builds
# without it: MAT v5 only, and a v7.3 file is a clear error.
FEATURES ?= mat73
CARGO_FEATURES := $(if $(strip $(FEATURES)),--features "$(addprefix isar-clutter/,$(FEATURES))")
# The Rust crates that `make test` and `make lint` build together. Not --workspace: the Python
# extension's pyo3 turns on features of shared dependencies (once_cell, syn, ...), and built
# together the binary's dependencies would be compiled a second time with them; maturin builds
# the extension on its own (`make python`).
RUST_PACKAGES := -p isar-clutter -p isar-clutter-core -p isar-clutter-tables -p isar-clutter-apps -p isar-clutter-runner -p isar-clutter-report
# mat73 links Debian's static libhdf5.a, through the HDF5_DIR that the `hdf5` target lays out
# (include/; lib/ with libhdf5.a alone; bin/ with the shared library that hdf5-metno-sys's build
# script loads to check the version). Linked dynamically, libhdf5 brings 33 more shared
# libraries (libcurl, krb5, ldap, ...) whose loading took 6 ms of every command's start on the
# development VM. Set HDF5_DIR to use another HDF5 installation.
HDF5_DIR ?= $(CARGO_TARGET_DIR)/hdf5-static
export HDF5_DIR

.PHONY: build run-experiment reproduce run-all compare validate test test-cuda test-deps python hdf5 lint fmt bench bench-scale bench-deps data bench-torch-deps bench-cnn-torch bench-cnn

## build: release build of the isar-clutter binary (with FEATURES; add `cuda` for
## `training: {device: cuda}`: make build FEATURES="mat73 cuda")
build: hdf5
	cargo build --release --locked $(CARGO_FEATURES)

## run-experiment: build and run SPEC (default: the Table 4 spec) into outputs/<name>/
run-experiment: build
	$(BIN) run $(SPEC) $(ARGS)

## reproduce: run the specs the dissertation's tables need (REPEATS runs of each random
## statistic, CNN_REPEATS of the repeated specs that train networks, resumable) into
## outputs/reproduction/ and write docs/reproduction.md (and the numbers it shows,
## docs/reproduction.json, which make test checks a fresh run against) from them; DEVICE=cuda
## (or auto) trains the networks on a GPU (give it its own ARGS="--out ... --doc ...")
REPEATS ?= 5
CNN_REPEATS ?= 2
reproduce: build
	$(BIN) reproduce --repeats $(REPEATS) --cnn-repeats $(CNN_REPEATS) $(if $(DEVICE),--device $(DEVICE)) $(ARGS)

## run-all: every shipped experiment into OUT/<name>/ (tables, maps, models; no report), e.g.
## before and after a change: make run-all OUT=/tmp/before; ...; make run-all OUT=/tmp/after
OUT ?= /tmp/isar-clutter-all
run-all: build data
	@for s in experiments/*.yaml; do n=$$(basename $$s .yaml); \
		$(BIN) run $$s --out $(OUT)/$$n --no-report >$(OUT).$$n.log 2>&1 || echo "$$n: exit $$? (see $(OUT).$$n.log)"; \
	done

## compare: value-for-value comparison of two output folders of run-all (or two runs)
compare: bench-deps
	$(VENV)/bin/python bench/compare_outputs.py $(BEFORE) $(AFTER)

## validate: check SPEC without running it
validate: build
	$(BIN) validate $(SPEC)

## test: every test, with the release profile (shares the release build's dependencies), then
## the Python package's tests (pytest, against the binary the Rust tests built)
test: test-deps python
	cargo test --release --locked $(RUST_PACKAGES) $(CARGO_FEATURES)
	ISAR_CLUTTER_BIN=$(BIN) $(PYVENV)/bin/python -m pytest -q python/tests

## test-cuda: training on a GPU (tests/cuda.rs: the cuDNN route against the CPU) in a build with
## the `cuda` feature: on a machine with an NVIDIA GPU, its driver, NVRTC and cuDNN 9 it trains
## there; elsewhere each test says it skipped
test-cuda: hdf5
	cargo test --release --locked --features "$(addprefix isar-clutter/,$(FEATURES) cuda)" --test cuda -- --nocapture

## python: the Python package isar_clutter (python/: maturin and pyo3 over the core crate)
## installed into PYVENV, a virtualenv under $HOME like the target directory, with what its tests
## need (pinned): pytest, numpy, rasterio (GDAL), sarpy (NGA's SICD library) and h5py, which
## write the GeoTIFF, SICD and HDF5 test files (h5py also reads HDF5 for isar_clutter.load), and PyTorch
## (the PyPI wheel, a large CUDA build; its CPU path is what the tests use). A user's own
## environment: pip install ./python
PYVENV ?= $(HOME)/.cache/isar-clutter/venv-python
PYVENV_DEPS := maturin==1.16.0 pytest==8.4.2 numpy==2.3.5 torch==2.15.0 rasterio==1.4.3 \
	sarpy==1.3.64 h5py==3.16.0
$(PYVENV)/.deps-3:
	$(PYTHON) -m venv $(PYVENV)
	$(PYVENV)/bin/pip install --quiet $(PYVENV_DEPS)
	touch $@
python: $(PYVENV)/.deps-3
	PATH=$(PYVENV)/bin:$$PATH $(PYVENV)/bin/pip install --quiet --no-build-isolation ./python

## hdf5: Debian's libhdf5-dev (and pkg-config) for the mat73 feature, installed with apt when
## running as root, otherwise a hint; then the static layout of HDF5_DIR (above) from it.
## Nothing when FEATURES leaves mat73 out.
HDF5_SERIAL := /usr/lib/$(shell gcc -print-multiarch 2>/dev/null)/hdf5/serial
hdf5:
	@case " $(FEATURES) " in *" mat73 "*) ;; *) exit 0 ;; esac; \
	if [ ! -f /usr/include/hdf5/serial/hdf5.h ] && [ ! -f /usr/include/hdf5.h ] && ! pkg-config --exists hdf5 2>/dev/null; then \
	if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing libhdf5-dev for MATLAB v7.3 files (apt-get)"; \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends libhdf5-dev pkg-config >/dev/null; \
	else \
		echo "libhdf5-dev not found: install Debian's libhdf5-dev for MATLAB v7.3 files, or build without them: make FEATURES="; exit 0; \
	fi; fi; \
	case "$(HDF5_DIR)" in "$(CARGO_TARGET_DIR)/hdf5-static") ;; *) exit 0 ;; esac; \
	rm -rf $(HDF5_DIR); \
	if [ -f $(HDF5_SERIAL)/libhdf5.a ] && [ -f $(HDF5_SERIAL)/libhdf5.so ] && [ -d /usr/include/hdf5/serial ]; then \
		mkdir -p $(HDF5_DIR)/lib $(HDF5_DIR)/bin && ln -sfn /usr/include/hdf5/serial $(HDF5_DIR)/include && \
		ln -sf $(HDF5_SERIAL)/libhdf5.a $(HDF5_DIR)/lib/libhdf5.a && ln -sf $(HDF5_SERIAL)/libhdf5.so $(HDF5_DIR)/bin/libhdf5.so; \
	elif pkg-config --exists hdf5 2>/dev/null; then \
		echo "no Debian libhdf5.a: linking the shared libhdf5 that pkg-config finds"; \
		mkdir -p $(HDF5_DIR) && ln -sfn "$$(pkg-config --variable=includedir hdf5)" $(HDF5_DIR)/include && \
		ln -sfn "$$(pkg-config --variable=libdir hdf5)" $(HDF5_DIR)/lib; \
	else \
		echo "no libhdf5 found (Debian's libhdf5-dev, or pkg-config): set HDF5_DIR to an HDF5 installation, or build without mat73: make FEATURES="; exit 1; \
	fi

## test-deps: libhdf5-dev (`hdf5`); SciPy, h5py, rasterio, sarpy, zarr, xarray and
## xarray-sentinel (pinned) in .venv for the MATLAB .mat, HDF5, GeoTIFF, Sentinel-1, SICD and
## Zarr tests;
## headless Chromium for the report's browser test (Debian's `chromium`; installed with apt
## when running as root, otherwise a hint). Under CI=true the browser and .mat tests fail
## without them rather than skipping.
TEST_DEPS := scipy==1.15.3 h5py==3.13.0 rasterio==1.4.3 sarpy==1.3.64 zarr==3.1.3 xarray==2025.10.1 xarray-sentinel==0.9.6
TEST_DEP_VERSIONS := ["1.15.3", "3.13.0", "1.4.3", "1.3.64", "3.1.3", "2025.10.1", "0.9.6"]
test-deps: hdf5 $(VENV)/bin/python
	@$(VENV)/bin/python -c 'import sys, scipy, h5py, rasterio, sarpy, zarr, xarray, xarray_sentinel; sys.exit([m.__version__ for m in (scipy, h5py, rasterio, sarpy, zarr, xarray, xarray_sentinel)] != $(TEST_DEP_VERSIONS))' 2>/dev/null || \
	{ echo "installing $(TEST_DEPS) into $(VENV) for the .mat, HDF5, GeoTIFF, SICD and Zarr tests (pip)"; \
	  $(VENV)/bin/pip install --quiet $(TEST_DEPS); }
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || \
	if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing chromium for the browser test (apt-get)"; \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium >/dev/null; \
	else \
		echo "chromium not found: install Debian's chromium for the report's browser test"; \
	fi

## lint: formatting and clippy with warnings as errors (also with the `cuda` feature, whose code
## no test here runs)
lint: hdf5
	cargo fmt --all -- --check
	cargo clippy --release $(RUST_PACKAGES) --all-targets --locked $(CARGO_FEATURES) -- -D warnings
	cargo clippy --release $(RUST_PACKAGES) --all-targets --locked -- -D warnings
	cargo clippy --release $(RUST_PACKAGES) --all-targets --locked --features "$(addprefix isar-clutter/,$(FEATURES) cuda)" -- -D warnings
	cargo clippy --release -p isar-clutter-python --locked -- -D warnings

fmt:
	cargo fmt --all

## bench-deps: a virtualenv with numpy for the side-by-side baselines (and the tests' Python;
## as root, Debian's python3-venv is installed when venv needs it)
$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV) || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1 && \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null && \
		rm -rf $(VENV) && $(PYTHON) -m venv $(VENV); }
	$(VENV)/bin/pip install --quiet numpy==2.3.5 pyarrow==21.0.0
bench-deps: $(VENV)/bin/python

## bench: every speed figure of BENCHMARKS.md side by side in one run, each next to its
## reference: generation stages against this thread's FMA peak (cargo bench --bench generate),
## the analysis kernel against the memory bandwidth measured in the same run (--bench analysis),
## isar-clutter run against numpy (bench/analysis_bench.py), isar-clutter generate against numpy
## and against writing the same bytes (bench/generate_bench.py), and sweeps of 1,000, 10,000 and
## 100,000 tiny jobs, local and 4 shards + merge (bench-scale)
bench: build bench-deps
	cargo bench --locked $(CARGO_FEATURES) --bench generate
	cargo bench --locked $(CARGO_FEATURES) --bench analysis
	$(VENV)/bin/python bench/analysis_bench.py --bin $(BIN)
	$(VENV)/bin/python bench/generate_bench.py --bin $(BIN)
	$(MAKE) bench-scale

## bench-scale: sweeps of tiny jobs (filtered noise 32 x 32, 50 samples, levels 2) run locally
## and as 4 shards + merge: wall, peak RSS, files, bytes on disk, the tool's time per job beyond
## the jobs' own (bench/scale_bench.py; JOBS to choose the sizes, SCALE_ARGS=--maps for the
## default map files; about 25 minutes on 2 cores with the default sizes)
JOBS ?= 1000 10000 100000
bench-scale: build bench-deps
	$(VENV)/bin/python bench/scale_bench.py --bin $(BIN) --jobs $(JOBS) $(SCALE_ARGS)

## bench-torch-deps: a separate virtualenv (.venv-torch) with a pinned PyTorch for the CNN
## reference benchmark (the PyPI wheel is a large CUDA build, ~5 GB installed; only its CPU
## path is used; numpy only silences torch's import warning)
VENV_TORCH := .venv-torch
TORCH_VERSION := 2.15.0
$(VENV_TORCH)/.torch-$(TORCH_VERSION):
	$(PYTHON) -m venv $(VENV_TORCH)
	$(VENV_TORCH)/bin/pip install --quiet torch==$(TORCH_VERSION) numpy==2.3.5
	touch $@
bench-torch-deps: $(VENV_TORCH)/.torch-$(TORCH_VERSION)

## bench-cnn-torch: PyTorch training throughput of the Table 18 and Table 23 CNNs on CPU
## (batch 128, SGD with momentum) with 1 and 2 threads; see BENCHMARKS.md
bench-cnn-torch: bench-torch-deps
	$(VENV_TORCH)/bin/python bench/cnn_torch.py --threads 1
	$(VENV_TORCH)/bin/python bench/cnn_torch.py --threads 2

## bench-cnn: CNN training throughput side by side in one run: burn (cargo bench --bench cnn:
## 1 and 2 threads, two trainings side by side) and PyTorch (1 and 2 threads)
bench-cnn: hdf5 bench-torch-deps
	cargo bench --locked $(CARGO_FEATURES) --bench cnn
	$(VENV_TORCH)/bin/python bench/cnn_torch.py --threads 1
	$(VENV_TORCH)/bin/python bench/cnn_torch.py --threads 2

## data: real data for the shipped experiments: NOAA's monthly surface winds
## (monthly_navy_winds.cdf, public domain) from Debian's ferret-datasets package, downloaded
## with apt (no root needed) and unpacked into data/ (ignored by git)
DATA_DIR := data
data: $(DATA_DIR)/monthly_navy_winds.cdf
$(DATA_DIR)/monthly_navy_winds.cdf:
	mkdir -p $(DATA_DIR)/.deb
	cd $(DATA_DIR)/.deb && apt-get download ferret-datasets
	dpkg -x $(DATA_DIR)/.deb/ferret-datasets_*.deb $(DATA_DIR)/.deb/root
	cp $(DATA_DIR)/.deb/root/usr/share/ferret-vis/data/monthly_navy_winds.cdf $@
	rm -rf $(DATA_DIR)/.deb
