//! soig from Python: the native module `soig._soig` under the `soig` package
//! (`soig-py/python/soig/`), which adds the docstrings' examples, the `Image` record and the
//! PyTorch dataset. Everything here calls the soig library as `soig run` does: a campaign is
//! its text, path and `--set` overrides composed by `Campaign::from_toml_with_overrides`, an
//! image is `simulate::image` (the GIL released while it renders), a run is `soig::run`.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use soig::scene::Inputs;
use soig::{Experiment, fits::Card};

// The CLI's allocator (see src/bin/soig/main.rs: each image allocates and frees multi-MB buffers).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

create_exception!(
    _soig,
    SoigError,
    PyException,
    "A soig run, input or output failed; the message names the file and what is wrong."
);
create_exception!(
    _soig,
    CampaignError,
    SoigError,
    "A campaign that does not parse or validate. Attributes: file, line (or None), field (or None), message."
);

/// A soig library error as a Python exception: a campaign's keeps its file, line and field.
fn to_py(e: soig::Error) -> PyErr {
    match e {
        soig::Error::Campaign(c) => campaign_err(c),
        other => SoigError::new_err(other.to_string()),
    }
}

fn campaign_err(c: soig::CampaignError) -> PyErr {
    let err = CampaignError::new_err(c.to_string());
    Python::attach(|py| {
        let v = err.value(py);
        // Setting attributes on a fresh exception instance cannot fail but for memory.
        let _ = v.setattr("file", c.file.display().to_string());
        let _ = v.setattr("line", c.line);
        let _ = v.setattr("field", c.field.clone());
        let _ = v.setattr("message", c.message.clone());
    });
    err
}

/// An `anyhow` error of a run as the library's typed error, then as a Python exception.
fn run_err(e: anyhow::Error) -> PyErr {
    to_py(soig::Error::from(e))
}

/// A Python value as the TOML value `--set key=value` would parse.
fn toml_value(v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(toml::Value::Integer(v.extract()?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| PyValueError::new_err(format!("campaign key {k}: not a string")))?;
            if x.is_none() {
                continue; // None leaves the key out: soig's default
            }
            t.insert(k, toml_value(&x)?);
        }
        return Ok(toml::Value::Table(t));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: PyResult<Vec<toml::Value>> = v.try_iter()?.map(|x| toml_value(&x?)).collect();
        return Ok(toml::Value::Array(items?));
    }
    Err(PyValueError::new_err(format!(
        "{}: not a campaign value (bool, int, float, str, list or dict)",
        v.repr()?
    )))
}

/// A JSON-serialisable value as plain Python objects (dicts, lists, numbers, strings).
fn to_python<'py>(py: Python<'py>, v: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| SoigError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// What images are rendered from, built once per campaign (frames and catalogue read).
struct Prepared {
    experiment: Experiment,
    inputs: Inputs,
    provenance: soig::Provenance,
}

/// A validated campaign. Its state is (text, path, overrides), so it pickles by those.
#[pyclass(module = "soig._soig", frozen)]
struct NativeCampaign {
    text: String,
    path: PathBuf,
    overrides: Vec<String>,
    campaign: Arc<soig::Campaign>,
    prepared: OnceLock<Arc<Prepared>>,
}

impl NativeCampaign {
    fn compose(text: String, path: PathBuf, overrides: Vec<String>) -> PyResult<NativeCampaign> {
        let campaign = soig::Campaign::from_toml_with_overrides(&text, &path, &overrides)
            .map_err(campaign_err)?;
        Ok(NativeCampaign {
            text,
            path,
            overrides,
            campaign: Arc::new(campaign),
            prepared: OnceLock::new(),
        })
    }

    fn prepared(&self, py: Python<'_>) -> PyResult<Arc<Prepared>> {
        if let Some(p) = self.prepared.get() {
            return Ok(p.clone());
        }
        let c = self.campaign.clone();
        let p = py
            .detach(move || -> Result<Prepared, soig::Error> {
                Ok(Prepared {
                    experiment: soig::experiment::of(&c),
                    inputs: soig::experiment::inputs(&c)?,
                    provenance: soig::Provenance::of(&c),
                })
            })
            .map_err(to_py)?;
        // Another thread may have prepared it meanwhile: the same values, either is fine.
        Ok(self.prepared.get_or_init(|| Arc::new(p)).clone())
    }
}

#[pymethods]
impl NativeCampaign {
    /// (text, path, overrides): a campaign file's text and the path naming it.
    #[staticmethod]
    #[pyo3(signature = (text, path, overrides=Vec::new()))]
    fn from_parts(text: String, path: PathBuf, overrides: Vec<String>) -> PyResult<Self> {
        NativeCampaign::compose(text, path, overrides)
    }

    /// Read a campaign file (as `soig run FILE` does).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        let text = soig::input_file::read_text(&path).map_err(|why| {
            campaign_err(soig::CampaignError {
                file: path.clone(),
                line: None,
                field: None,
                message: format!("campaign file: {why}"),
            })
        })?;
        NativeCampaign::compose(text, path, Vec::new())
    }

    /// A dict (nested tables) as campaign TOML text.
    #[staticmethod]
    fn dict_to_toml(d: &Bound<'_, PyDict>) -> PyResult<String> {
        match toml_value(d.as_any())? {
            toml::Value::Table(t) => {
                toml::to_string(&t).map_err(|e| PyValueError::new_err(e.to_string()))
            }
            _ => unreachable!("a dict is a table"),
        }
    }

    /// `key=value` as `--set` writes it (the value a Python value, as TOML), unchecked: the
    /// campaign judges its overrides together when it is built (`from_parts`).
    #[staticmethod]
    fn override_text(key: &str, value: &Bound<'_, PyAny>) -> PyResult<String> {
        Ok(format!("{key}={}", toml_value(value)?))
    }

    /// This campaign with `key=value` added to its overrides (the value a Python value).
    fn with_set(&self, key: &str, value: &Bound<'_, PyAny>) -> PyResult<Self> {
        let v = toml_value(value)?;
        let mut overrides = self.overrides.clone();
        overrides.push(format!("{key}={v}"));
        NativeCampaign::compose(self.text.clone(), self.path.clone(), overrides)
    }

    #[getter]
    fn text(&self) -> &str {
        &self.text
    }
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }
    #[getter]
    fn overrides(&self) -> Vec<String> {
        self.overrides.clone()
    }
    #[getter]
    fn name(&self) -> &str {
        &self.campaign.resolved.name
    }
    #[getter]
    fn images(&self) -> u32 {
        self.campaign.resolved.images
    }
    #[getter]
    fn seed(&self) -> u64 {
        self.campaign.resolved.seed
    }
    #[getter]
    fn hash(&self) -> &str {
        &self.campaign.hash
    }
    #[getter]
    fn output_dir(&self) -> PathBuf {
        self.campaign.output_dir.clone()
    }
    /// The resolved campaign (defaults filled, TLE files read) as a dict: what the hash covers.
    #[getter]
    fn resolved<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.campaign.resolved)
    }

    /// Render image `index`: a dict of numpy arrays and records (see `soig.Image`).
    fn image<'py>(&self, py: Python<'py>, index: u64) -> PyResult<Bound<'py, PyDict>> {
        let n = self.campaign.resolved.images as u64;
        if index >= n {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "image {index}: the campaign has {n} images (0..{n})"
            )));
        }
        let p = self.prepared(py)?;
        let campaign = self.campaign.clone();
        let q = p.clone();
        let products = py
            .detach(move || soig::simulate::image(&q.experiment, &q.inputs, index))
            .map_err(|e| {
                // As `soig run` says it: at the debris entry no draw could show.
                let at = campaign.error_at(&format!("debris[{}]", e.debris_index), e.to_string());
                campaign_err(at)
            })?;
        let exposure = &products.exposure;
        let (w, h) = (exposure.width, exposure.height);
        // What `soig run` refuses to write, this refuses to return (an extreme gain or frame).
        let bad = exposure.adu.iter().filter(|v| !v.is_finite()).count();
        if bad > 0 {
            return Err(SoigError::new_err(format!(
                "image {index}: {bad} non-finite pixels in the noisy image (sensor.gain_e_per_adu {})",
                self.campaign.resolved.sensor.gain_e_per_adu
            )));
        }
        let cards = soig::provenance_cards(
            &p.provenance,
            &p.experiment.sensor,
            &products.scene,
            exposure,
        );
        let header = PyDict::new(py);
        for (key, value, _) in &cards {
            match value {
                Card::Int(i) => header.set_item(key, i)?,
                Card::Real(r) => header.set_item(key, r)?,
                Card::Str(s) => header.set_item(key, s)?,
            }
        }
        let out = PyDict::new(py);
        out.set_item("index", index)?;
        // The FITS's pixels: float32 ADU, and the noise-free electrons as int32 (clamped as
        // the writer does).
        out.set_item(
            "noisy",
            exposure.adu.clone().into_pyarray(py).reshape([h, w])?,
        )?;
        let clean = soig::product::records::clean_counts(exposure);
        out.set_item("clean", clean.into_pyarray(py).reshape([h, w])?)?;
        // The truth sidecar as `soig run` writes it: one object, or the frame and its objects.
        let truth = to_python(py, &soig::product::records::truth(&products))?;
        out.set_item("truth", truth)?;
        out.set_item("header", header)?;
        match &products.product {
            Some(f) => {
                let g = &f.png;
                out.set_item(
                    "png",
                    g.pixels
                        .clone()
                        .into_pyarray(py)
                        .reshape([g.height, g.width])?,
                )?;
                out.set_item("label", soig::product::records::label_text(f))?;
                // The first box (the one object of a campaign without `[objects]`), and all.
                let edges: Vec<(f64, f64, f64, f64)> = soig::product::records::label_edges(f)
                    .into_iter()
                    .map(|[a, b, c, d]| (a, b, c, d))
                    .collect();
                out.set_item("label_box", edges.first())?;
                out.set_item("label_boxes", edges)?;
            }
            None => {
                out.set_item("png", py.None())?;
                out.set_item("label", py.None())?;
                out.set_item("label_box", py.None())?;
                out.set_item("label_boxes", py.None())?;
            }
        }
        Ok(out)
    }
}

/// A run's progress that reports nothing and stops when asked (Ctrl-C in Python).
struct Cancel(Arc<std::sync::atomic::AtomicBool>);

impl soig::Progress for Cancel {
    fn cancelled(&self) -> bool {
        self.0.load(std::sync::atomic::Ordering::SeqCst)
    }
}

/// Run a campaign into `out` as `soig run` does; returns the run summary as a dict.
#[pyfunction]
#[pyo3(signature = (campaign, out, fresh=false, python=None, force=false))]
fn run<'py>(
    py: Python<'py>,
    campaign: &NativeCampaign,
    out: PathBuf,
    fresh: bool,
    python: Option<PathBuf>,
    force: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let c = campaign.campaign.clone();
    // The run goes on in a thread of its own while this one, every 0.1 s, lets Python see its
    // signals: Ctrl-C then stops the run before its next image (`Progress::cancelled`), leaves
    // its work to resume, and raises KeyboardInterrupt here.
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let cancel = Cancel(stop.clone());
    let worker = std::thread::spawn(move || {
        let options = soig::RunOptions {
            shard: None,
            fresh,
            force,
        };
        soig::run_with(&c, &out, options, python.as_deref(), &cancel)
    });
    loop {
        py.detach(|| {
            for _ in 0..10 {
                if worker.is_finished() {
                    break;
                }
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
        });
        if worker.is_finished() {
            break;
        }
        if let Err(interrupt) = py.check_signals() {
            stop.store(true, std::sync::atomic::Ordering::SeqCst);
            let _ = py.detach(|| worker.join());
            return Err(interrupt);
        }
    }
    let s = worker
        .join()
        .map_err(|_| SoigError::new_err("the run panicked"))?
        .map_err(run_err)?;
    let d = PyDict::new(py);
    d.set_item("output", s.output)?;
    d.set_item("digest", s.digest)?;
    d.set_item("images", s.images)?;
    d.set_item("resumed", s.resumed)?;
    d.set_item("seconds", s.seconds)?;
    d.set_item("mix", to_python(py, &s.mix)?)?;
    Ok(d)
}

/// The build identity that keeps two builds out of one output: sha256 of this extension
/// module's file (`soig::build_id`).
#[pyfunction]
fn build_id() -> String {
    soig::build_id::identity().to_string()
}

/// Check an output against its manifest, as `soig verify`.
#[pyfunction]
fn verify<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let (m, problems) = py.detach(|| soig::verify(&path)).map_err(to_py)?;
    let d = PyDict::new(py);
    d.set_item("ok", problems.is_empty())?;
    d.set_item("digest", &m.digest)?;
    d.set_item("files", m.files.len())?;
    d.set_item(
        "problems",
        problems.iter().map(|p| p.to_string()).collect::<Vec<_>>(),
    )?;
    Ok(d)
}

/// Precision, recall and mAP of YOLO prediction files against label files, as `soig eval
/// --json` (the same keys).
#[allow(clippy::too_many_arguments)] // the command's options, as keyword arguments
#[pyfunction]
#[pyo3(signature = (labels, predictions, mode="ultralytics", images=None, image_size=1024, conf=0.5, iou=0.5))]
fn eval<'py>(
    py: Python<'py>,
    labels: PathBuf,
    predictions: PathBuf,
    mode: &str,
    images: Option<PathBuf>,
    image_size: u32,
    conf: f64,
    iou: f64,
) -> PyResult<Bound<'py, PyAny>> {
    use soig::metrics;
    if mode != "ultralytics" && mode != "coco" {
        return Err(PyValueError::new_err(format!(
            "mode {mode:?}: one of \"ultralytics\", \"coco\""
        )));
    }
    let options = metrics::EvalOptions {
        mode: if mode == "ultralytics" {
            metrics::EvalMode::Ultralytics
        } else {
            metrics::EvalMode::Coco
        },
        images: images.as_deref(),
        image_size,
        conf,
        iou,
    };
    let json = py
        .detach(|| metrics::eval_dirs(&labels, &predictions, options).map(|e| e.to_json()))
        .map_err(|e| SoigError::new_err(format!("{e:#}")))?;
    to_python(py, &json)
}

/// Run the detectors on frame files (FITS or PNG) into `out`, as `soig detect`; returns the
/// per-frame results (detections in pixel-edge coordinates) and the output's digest.
#[allow(clippy::too_many_arguments)] // the command's options, as keyword arguments
#[pyfunction]
#[pyo3(signature = (inputs, out, detector=None, model=None, campaign=None, psf_fwhm_px=None, star_trail_angle_deg=None, conf=None))]
fn detect_files<'py>(
    py: Python<'py>,
    inputs: Vec<PathBuf>,
    out: PathBuf,
    detector: Option<&str>,
    model: Option<PathBuf>,
    campaign: Option<&NativeCampaign>,
    psf_fwhm_px: Option<f64>,
    star_trail_angle_deg: Option<f64>,
    conf: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    use soig::detect_frames::{Options, Which};
    use soig::verbs::plan::Plan;
    // As the CLI: the streak detector alone unless a model is given.
    let which = match (detector, &model) {
        (Some("streak"), _) | (None, None) => Which::Streak,
        (Some("yolo"), _) => Which::Yolo,
        (Some("all"), _) | (None, Some(_)) => Which::All,
        (Some(other), _) => {
            return Err(PyValueError::new_err(format!(
                "detector {other:?}: one of \"streak\", \"yolo\", \"all\""
            )));
        }
    };
    let c = campaign.map(|c| c.campaign.clone());
    let plan = c.as_deref().map(Plan::new).transpose().map_err(run_err)?;
    let mut opts = Options::new(plan.as_ref(), which, model);
    opts.optics.psf_fwhm_px = psf_fwhm_px;
    opts.star_trail_angle_deg = star_trail_angle_deg;
    if let Some(c) = conf {
        opts.yolo.conf = c;
    }
    let s = py
        .detach(|| soig::detect_frames::run(&inputs, &out, &opts))
        .map_err(run_err)?;
    let d = PyDict::new(py);
    d.set_item("frames", to_python(py, &s.frames)?)?;
    d.set_item("output", s.output)?;
    d.set_item("digest", s.digest)?;
    Ok(d)
}

/// Write a 2-D array as the frame file `soig detect` reads: float32 values as a FITS, uint8
/// grey levels as a PNG; atomically (an old file at `path` is replaced whole or kept).
#[pyfunction]
fn write_frame(array: &Bound<'_, PyAny>, path: PathBuf) -> PyResult<()> {
    if let Ok(a) = array.extract::<PyReadonlyArray2<'_, u8>>() {
        let [h, w] = [a.shape()[0], a.shape()[1]];
        let g = soig::enhance::Gray8 {
            width: w,
            height: h,
            pixels: a.as_array().iter().copied().collect(),
        };
        return soig::store::fs::write(&path, soig::enhance::png_bytes(&g))
            .map_err(|e| SoigError::new_err(format!("{e:#}")));
    }
    let a: PyReadonlyArray2<'_, f32> = array.extract().map_err(|_| {
        PyValueError::new_err("a frame is a 2-D numpy array of float32 values or uint8 grey levels")
    })?;
    let [h, w] = [a.shape()[0], a.shape()[1]];
    let v: Vec<f32> = a.as_array().iter().copied().collect();
    soig::store::fs::write_by(&path, |temp| {
        Ok(soig::fits::write_image(
            temp,
            w,
            h,
            soig::fits::Pixels::F32(&v),
            &Vec::new(),
        )?)
    })
    .map_err(|e| SoigError::new_err(format!("{e:#}")))
}

#[pymodule]
fn _soig(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SoigError", m.py().get_type::<SoigError>())?;
    m.add("CampaignError", m.py().get_type::<CampaignError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<NativeCampaign>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(build_id, m)?)?;
    m.add_function(wrap_pyfunction!(verify, m)?)?;
    m.add_function(wrap_pyfunction!(eval, m)?)?;
    m.add_function(wrap_pyfunction!(detect_files, m)?)?;
    m.add_function(wrap_pyfunction!(write_frame, m)?)?;
    Ok(())
}
