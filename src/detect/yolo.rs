//! YOLOv8 detection on 8-bit greyscale images through ONNX Runtime, reproducing Ultralytics'
//! `YOLO(model.onnx).predict(...)` (checked against Ultralytics 8.4.190, OpenCV 5.0, torchvision
//! 0.29, onnxruntime 1.32; see `tests/reference/yolo_reference.py`).
//!
//! Pipeline, step by step as Ultralytics does it:
//! 1. `LetterBox` (`ultralytics/data/augment.py`): scale by `r = min(H/h, W/w)`, resize to
//!    `(round(w r), round(h r))` (Python's round-half-even) with `cv2.resize(..., INTER_LINEAR)`, pad
//!    with 114 centred (`top = round(dh/2 - 0.1)`, `bottom = round(dh/2 + 0.1)`). `auto=False` for
//!    static exports; for dynamic-shape exports Ultralytics pads only to a multiple of the stride
//!    (`auto=True`), and so does this module. The resize is a bit-exact port of OpenCV's 8-bit
//!    fixed-point bilinear (`INTER_RESIZE_COEF_BITS = 11`), including its switch to `INTER_AREA`
//!    for an exact 2x reduction.
//! 2. Greyscale replicated to 3 channels (what `cv2.imread(IMREAD_COLOR)` does), `u8 / 255` in f32.
//! 3. Output `(1, 4 + nc, N)`: `xc, yc, w, h` then class scores (no NMS in the graph).
//! 4. `non_max_suppression` (`ultralytics/utils/nms.py`, `agnostic=False`, `multi_label=False`):
//!    keep anchors whose best class score is `> conf`, boxes to xyxy in f32, offset by
//!    `class * 7680`, `torchvision.ops.nms` (stable descending sort by score, suppress when
//!    IoU `> iou`, f32 arithmetic), first `max_det`.
//! 5. `scale_boxes` (`ultralytics/utils/ops.py`): subtract the padding, divide by
//!    `round(side * gain) / side` per axis, clip to the image.
//!
//! ONNX Runtime is loaded at run time (`ort`'s `load-dynamic`): see [`find_onnxruntime`]. The
//! number of intra-op threads is [`YoloParams::intra_threads`] (default 1): ONNX Runtime's own
//! thread pool slows down several-fold when another thread pool (rayon) is busy on the same cores,
//! so use more than one thread only when detection runs alone. Pool threads do not spin-wait.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use ort::environment::Environment;
use ort::session::Session;
use ort::session::builder::GraphOptimizationLevel;
use ort::value::{TensorElementType, TensorRef, ValueType};

use super::Detection;
use crate::python;

/// Ultralytics' `max_wh`: class offset added to boxes so that NMS never mixes classes.
const MAX_WH: f32 = 7680.0;
/// Ultralytics' `max_nms`: at most this many candidates (highest scores) go into NMS.
const MAX_NMS: usize = 30_000;
/// Ultralytics' letterbox padding value.
const PAD_VALUE: u8 = 114;
/// Side used when the model's input size is dynamic and no `imgsz` is given.
const DEFAULT_IMGSZ: u32 = 640;
/// YOLOv8 detection strides (P3, P4, P5).
const STRIDES: [u32; 3] = [8, 16, 32];

/// Default confidence threshold (the paper's; also the campaign's `detect.conf` default).
pub const DEFAULT_CONF: f64 = 0.5;
/// Default NMS IoU threshold (the paper's; also the campaign's `detect.iou` default).
pub const DEFAULT_IOU: f64 = 0.5;
/// Default cap on detections per image (Ultralytics'; also the campaign's `detect.max_det`).
pub const DEFAULT_MAX_DET: u32 = 300;

/// Detection settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YoloParams {
    /// Confidence threshold: keep boxes whose best class score is strictly greater (paper: 0.5).
    pub conf: f64,
    /// IoU threshold for NMS: suppress boxes overlapping a better one by strictly more (paper: 0.5).
    pub iou: f64,
    /// At most this many detections per image (Ultralytics: 300).
    pub max_det: usize,
    /// Square network input side. `None`: the model's input shape if static, else 640. A value
    /// that contradicts a static input shape is an error.
    pub imgsz: Option<u32>,
    /// ONNX Runtime intra-op threads (default 1; 0 lets ONNX Runtime pick, one per core). More
    /// threads help only when nothing else is running: ONNX Runtime slows down badly when its
    /// pool competes with another busy pool.
    pub intra_threads: usize,
}

impl Default for YoloParams {
    fn default() -> Self {
        Self {
            conf: DEFAULT_CONF,
            iou: DEFAULT_IOU,
            max_det: DEFAULT_MAX_DET as usize,
            imgsz: None,
            intra_threads: 1,
        }
    }
}

/// Errors of model loading and detection.
#[derive(thiserror::Error, Debug, Clone, PartialEq)]
pub enum YoloError {
    #[error(
        "ONNX Runtime shared library not found (searched: {searched}). Install it with the project's \
         setup, i.e. `pip install onnxruntime` (the PyPI wheel ships onnxruntime/capi/libonnxruntime.so), \
         or set ORT_DYLIB_PATH to the library file"
    )]
    OnnxRuntimeNotFound { searched: String },
    #[error(
        "ORT_DYLIB_PATH is set to {0}, which does not exist; unset it or point it at libonnxruntime.so"
    )]
    OrtDylibPathMissing(PathBuf),
    #[error(
        "cannot load ONNX Runtime from {path}: {message} (reinstall or upgrade it with \
         `pip install -U onnxruntime`, or point ORT_DYLIB_PATH at another libonnxruntime.so)"
    )]
    OnnxRuntimeLoad { path: PathBuf, message: String },
    #[error("YOLO model file {0} not found")]
    ModelNotFound(PathBuf),
    #[error("cannot load {path} as an ONNX model: {message}")]
    ModelLoad { path: PathBuf, message: String },
    #[error("{path} is not a YOLOv8 detection model as exported by Ultralytics: {message}")]
    NotYolov8 { path: PathBuf, message: String },
    #[error("invalid YOLO parameters: {0}")]
    Params(String),
    #[error("invalid image: {0}")]
    Image(String),
    #[error("ONNX Runtime inference failed: {0}")]
    Inference(String),
}

/// A loaded YOLOv8 detector. Not shareable between threads while detecting (`detect` takes
/// `&mut self`); load one per thread if needed.
pub struct YoloDetector {
    session: Session,
    params: YoloParams,
    /// Network input (height, width) for static models; the letterbox target for dynamic ones.
    target: (u32, u32),
    /// `Some(stride)` when the input shape is dynamic: pad only to a multiple of the stride.
    auto_stride: Option<u32>,
    /// Input channels expected by the model (3, or 1 for a greyscale model).
    channels: usize,
    /// Number of classes (`output rows - 4`).
    nc: usize,
    /// Reused input buffer.
    input: Vec<f32>,
}

impl std::fmt::Debug for YoloDetector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("YoloDetector")
            .field("params", &self.params)
            .field("target", &self.target)
            .field("auto_stride", &self.auto_stride)
            .field("channels", &self.channels)
            .field("nc", &self.nc)
            .finish_non_exhaustive()
    }
}

/// The process-wide ONNX Runtime environment (`ort` allows one per process).
static ORT_ENV: Mutex<Option<Environment>> = Mutex::new(None);

fn ort_environment() -> Result<Environment, YoloError> {
    let mut guard = ORT_ENV.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(env) = guard.as_ref() {
        return Ok(env.clone());
    }
    let path = find_onnxruntime()?;
    let load_err = |message: String| YoloError::OnnxRuntimeLoad {
        path: path.clone(),
        message,
    };
    let builder = ort::init_from(&path).map_err(|e| load_err(e.to_string()))?;
    let env = builder
        .with_name("soig-yolo")
        .with_telemetry(false)
        .build()
        .map_err(|e| load_err(e.to_string()))?;
    *guard = Some(env.clone());
    Ok(env)
}

fn not_yolo(path: &Path, message: impl Into<String>) -> YoloError {
    YoloError::NotYolov8 {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

fn tensor_shape(dtype: &ValueType) -> Option<(TensorElementType, Vec<i64>)> {
    match dtype {
        ValueType::Tensor { ty, shape, .. } => Some((*ty, shape.iter().copied().collect())),
        _ => None,
    }
}

/// Number of anchors YOLOv8 produces for an input of `h` x `w`.
fn anchor_count(h: u32, w: u32) -> i64 {
    STRIDES
        .iter()
        .map(|&s| i64::from(h.div_ceil(s)) * i64::from(w.div_ceil(s)))
        .sum()
}

fn check_params(p: &YoloParams) -> Result<(), YoloError> {
    if !(0.0..=1.0).contains(&p.conf) {
        return Err(YoloError::Params(format!(
            "conf must be in [0, 1], got {}",
            p.conf
        )));
    }
    if !(0.0..=1.0).contains(&p.iou) {
        return Err(YoloError::Params(format!(
            "iou must be in [0, 1], got {}",
            p.iou
        )));
    }
    if p.imgsz == Some(0) {
        return Err(YoloError::Params("imgsz must be positive".into()));
    }
    Ok(())
}

impl YoloDetector {
    /// Load a YOLOv8 ONNX (Ultralytics export: input (1,3,H,W) float 0..1 RGB, output
    /// (1, 4+nc, N) = xc,yc,w,h + class scores, no NMS). Validates shapes.
    pub fn load(model: &Path, params: YoloParams) -> Result<Self, YoloError> {
        check_params(&params)?;
        if !model.is_file() {
            return Err(YoloError::ModelNotFound(model.to_path_buf()));
        }
        let env = ort_environment()?;
        let model_err = |message: String| YoloError::ModelLoad {
            path: model.to_path_buf(),
            message,
        };
        let session = Session::builder(&env)
            .map_err(|e| model_err(e.to_string()))?
            .with_optimization_level(GraphOptimizationLevel::Level3)
            .map_err(|e| model_err(e.to_string()))?
            .with_intra_threads(params.intra_threads)
            .map_err(|e| model_err(e.to_string()))?
            .with_inter_threads(1)
            .map_err(|e| model_err(e.to_string()))?
            // Idle pool threads sleep instead of spinning: spinning costs little when the machine
            // is idle but ~1.5-2x when other work competes for the cores (measured on 2 cores).
            .with_intra_op_spinning(false)
            .map_err(|e| model_err(e.to_string()))?
            .commit_from_file(model)
            .map_err(|e| model_err(e.to_string()))?;

        // Ultralytics writes its own metadata (task, stride, imgsz, names) into the export.
        let (task, meta_stride) = match session.metadata() {
            Ok(m) => (
                m.custom("task"),
                m.custom("stride")
                    .and_then(|s| s.trim().parse::<u32>().ok()),
            ),
            Err(_) => (None, None),
        };
        if let Some(task) = task
            && task != "detect"
        {
            return Err(not_yolo(
                model,
                format!("its task is '{task}', not 'detect'"),
            ));
        }

        let inputs = session.inputs();
        if inputs.len() != 1 {
            return Err(not_yolo(
                model,
                format!("expected 1 input, found {}", inputs.len()),
            ));
        }
        let Some((ity, ishape)) = tensor_shape(inputs[0].dtype()) else {
            return Err(not_yolo(model, "the input is not a tensor"));
        };
        if ity != TensorElementType::Float32 {
            return Err(not_yolo(
                model,
                format!("input element type is {ity:?}, expected float32"),
            ));
        }
        let valid_in = ishape.len() == 4
            && matches!(ishape[0], 1 | -1)
            && matches!(ishape[1], 1 | 3)
            && ishape[2] != 0
            && ishape[3] != 0
            && ishape[2] >= -1
            && ishape[3] >= -1;
        if !valid_in {
            return Err(not_yolo(
                model,
                format!("input shape {ishape:?}, expected (1, 3, H, W)"),
            ));
        }
        let channels = ishape[1] as usize;

        let outputs = session.outputs();
        if outputs.len() != 1 {
            return Err(not_yolo(
                model,
                format!(
                    "expected 1 output (1, 4+nc, N), found {} outputs (segmentation/pose model?)",
                    outputs.len()
                ),
            ));
        }
        let Some((oty, oshape)) = tensor_shape(outputs[0].dtype()) else {
            return Err(not_yolo(model, "the output is not a tensor"));
        };
        if oty != TensorElementType::Float32 {
            return Err(not_yolo(
                model,
                format!("output element type is {oty:?}, expected float32"),
            ));
        }
        if oshape.len() != 3
            || !matches!(oshape[0], 1 | -1)
            || oshape[1] < 5
            || oshape[2] == 0
            || oshape[2] < -1
        {
            return Err(not_yolo(
                model,
                format!(
                    "output shape {oshape:?}, expected (1, 4+nc, N): xc, yc, w, h and class scores per anchor"
                ),
            ));
        }
        let nc = (oshape[1] - 4) as usize;

        let static_input = ishape[2] > 0 && ishape[3] > 0;
        let stride = meta_stride.filter(|&s| s > 0).unwrap_or(32);
        let (target, auto_stride) = if static_input {
            let (h, w) = (ishape[2] as u32, ishape[3] as u32);
            if let Some(s) = params.imgsz
                && (s, s) != (h, w)
            {
                return Err(YoloError::Params(format!(
                    "imgsz {s} does not match the model's static input {w}x{h}; use imgsz None or re-export"
                )));
            }
            if oshape[2] > 0 && oshape[2] != anchor_count(h, w) {
                return Err(not_yolo(
                    model,
                    format!(
                        "output shape {oshape:?}: {} anchors expected for a {w}x{h} input (end-to-end/NMS export?)",
                        anchor_count(h, w)
                    ),
                ));
            }
            ((h, w), None)
        } else {
            // Ultralytics' check_imgsz: round up to a multiple of the stride.
            let s = params
                .imgsz
                .unwrap_or(DEFAULT_IMGSZ)
                .div_ceil(stride)
                .max(1)
                * stride;
            ((s, s), Some(stride))
        };

        Ok(Self {
            session,
            params,
            target,
            auto_stride,
            channels,
            nc,
            input: Vec::new(),
        })
    }

    /// Network input size as (width, height): the static input shape, or for dynamic-shape
    /// models the letterbox target (the actual input is padded only to a stride multiple).
    pub fn input_size(&self) -> (u32, u32) {
        (self.target.1, self.target.0)
    }

    /// Number of classes of the model.
    pub fn num_classes(&self) -> usize {
        self.nc
    }

    /// The parameters the detector was loaded with.
    pub fn params(&self) -> &YoloParams {
        &self.params
    }

    /// Letterbox exactly as Ultralytics' LetterBox (auto=False for exported static models,
    /// center=True, the same rounding of padding, bilinear resize as cv2.INTER_LINEAR, pad value
    /// 114), greyscale replicated to 3 channels, decode, class-aware NMS (torchvision.ops.nms
    /// semantics, as Ultralytics non_max_suppression with agnostic=False), scale boxes back
    /// (scale_boxes with its clipping), return sorted by score (best first).
    ///
    /// `gray` is row-major, `width * height` bytes.
    pub fn detect(
        &mut self,
        gray: &[u8],
        width: usize,
        height: usize,
    ) -> Result<Vec<Detection>, YoloError> {
        if width == 0 || height == 0 {
            return Err(YoloError::Image(format!("empty image {width}x{height}")));
        }
        if width.checked_mul(height) != Some(gray.len()) {
            return Err(YoloError::Image(format!(
                "buffer has {} bytes, expected {width}x{height} = {}",
                gray.len(),
                width.saturating_mul(height)
            )));
        }
        let lb = letterbox_gray(
            gray,
            width,
            height,
            self.target.0 as usize,
            self.target.1 as usize,
            self.auto_stride,
        );
        let plane = lb.width * lb.height;
        self.input.clear();
        self.input.reserve(plane * self.channels);
        let lut: [f32; 256] = std::array::from_fn(|v| v as f32 / 255.0);
        self.input.extend(lb.data.iter().map(|&v| lut[v as usize]));
        for _ in 1..self.channels {
            self.input.extend_from_within(..plane);
        }

        let ierr = |e: ort::Error| YoloError::Inference(e.to_string());
        let shape = [1usize, self.channels, lb.height, lb.width];
        let tensor = TensorRef::from_array_view((shape, &self.input[..])).map_err(ierr)?;
        let outputs = self.session.run(ort::inputs![tensor]).map_err(ierr)?;
        let (oshape, data) = outputs[0].try_extract_tensor::<f32>().map_err(ierr)?;
        let oshape: Vec<i64> = oshape.iter().copied().collect();
        if oshape.len() != 3 || oshape[0] != 1 || oshape[1] != (4 + self.nc) as i64 {
            return Err(YoloError::Inference(format!(
                "unexpected output shape {oshape:?}"
            )));
        }
        let n = oshape[2] as usize;
        let kept = nms_decode(
            data,
            self.nc,
            n,
            self.params.conf,
            self.params.iou,
            self.params.max_det,
        );
        Ok(scale_boxes(&kept, (lb.height, lb.width), (height, width)))
    }
}

/// A letterboxed single-channel image.
#[derive(Clone, Debug, PartialEq)]
pub struct Letterboxed {
    /// Row-major pixels, `width * height`.
    pub data: Vec<u8>,
    pub width: usize,
    pub height: usize,
    /// Size of the resized image inside the padding.
    pub new_width: usize,
    pub new_height: usize,
    pub left: usize,
    pub top: usize,
}

/// Python's `round()` of a float to an integer (round half to even).
fn py_round(x: f64) -> i64 {
    x.round_ties_even() as i64
}

/// Ultralytics' `LetterBox(new_shape=(new_h, new_w), auto=auto_stride.is_some(), stride,
/// center=True, scaleup=True)` applied to a single-channel image.
pub fn letterbox_gray(
    gray: &[u8],
    width: usize,
    height: usize,
    new_h: usize,
    new_w: usize,
    auto_stride: Option<u32>,
) -> Letterboxed {
    let r = f64::min(new_h as f64 / height as f64, new_w as f64 / width as f64);
    let uw = py_round(width as f64 * r).max(1) as usize;
    let uh = py_round(height as f64 * r).max(1) as usize;
    let (mut dw, mut dh) = (new_w as i64 - uw as i64, new_h as i64 - uh as i64);
    if let Some(s) = auto_stride {
        dw = dw.rem_euclid(i64::from(s));
        dh = dh.rem_euclid(i64::from(s));
    }
    let (dw, dh) = (dw as f64 / 2.0, dh as f64 / 2.0);
    let (top, bottom) = (py_round(dh - 0.1), py_round(dh + 0.1));
    let (left, right) = (py_round(dw - 0.1), py_round(dw + 0.1));
    // Negative padding cannot happen with scaleup=True (uw <= new_w), but clamp defensively.
    let (top, bottom, left, right) = (
        top.max(0) as usize,
        bottom.max(0) as usize,
        left.max(0) as usize,
        right.max(0) as usize,
    );
    let resized;
    let img: &[u8] = if (uw, uh) == (width, height) {
        gray
    } else {
        resized = resize_linear_u8(gray, width, height, uw, uh);
        &resized
    };
    let (ow, oh) = (uw + left + right, uh + top + bottom);
    let mut data = vec![PAD_VALUE; ow * oh];
    for y in 0..uh {
        let dst = (y + top) * ow + left;
        data[dst..dst + uw].copy_from_slice(&img[y * uw..(y + 1) * uw]);
    }
    Letterboxed {
        data,
        width: ow,
        height: oh,
        new_width: uw,
        new_height: uh,
        left,
        top,
    }
}

const COEF_BITS: u32 = 11; // OpenCV INTER_RESIZE_COEF_BITS
const COEF_SCALE: f32 = (1 << COEF_BITS) as f32;

/// OpenCV's `cvFloor` of a float.
fn cv_floor(x: f32) -> i64 {
    let i = x as i64;
    i - i64::from((i as f32) > x)
}

/// OpenCV's `saturate_cast<short>(float)` (round half to even, then clamp).
fn to_short(x: f32) -> i32 {
    (x.round_ties_even() as i32).clamp(i16::MIN as i32, i16::MAX as i32)
}

/// `cv2.resize(src, (dw, dh), interpolation=cv2.INTER_LINEAR)` for one 8-bit channel,
/// bit-exact with OpenCV's fixed-point path (`resizeGeneric_` with `HResizeLinear` /
/// `VResizeLinear<uchar, int, short, FixedPtCast<int, uchar, 22>>`), including OpenCV's use of
/// `INTER_AREA` when both axes shrink exactly 2x.
pub fn resize_linear_u8(src: &[u8], sw: usize, sh: usize, dw: usize, dh: usize) -> Vec<u8> {
    assert_eq!(src.len(), sw * sh, "resize_linear_u8: buffer size");
    assert!(
        sw > 0 && sh > 0 && dw > 0 && dh > 0,
        "resize_linear_u8: empty image"
    );
    let inv_scale_x = dw as f64 / sw as f64;
    let inv_scale_y = dh as f64 / sh as f64;
    let scale_x = 1.0 / inv_scale_x;
    let scale_y = 1.0 / inv_scale_y;
    let iscale_x = scale_x.round_ties_even();
    let iscale_y = scale_y.round_ties_even();
    let is_area_fast =
        (scale_x - iscale_x).abs() < f64::EPSILON && (scale_y - iscale_y).abs() < f64::EPSILON;
    if is_area_fast && iscale_x == 2.0 && iscale_y == 2.0 {
        return resize_area_fast_2x(src, sw, dw, dh);
    }

    // Horizontal coefficients: source index and fixed-point weights, clamped at the borders.
    let mut xofs = Vec::with_capacity(dw);
    let mut xalpha = Vec::with_capacity(dw);
    for dx in 0..dw {
        let mut fx = ((dx as f64 + 0.5) * scale_x - 0.5) as f32;
        let mut sx = cv_floor(fx);
        fx -= sx as f32;
        if sx < 0 {
            fx = 0.0;
            sx = 0;
        }
        if sx >= sw as i64 - 1 {
            fx = 0.0;
            sx = sw as i64 - 1;
        }
        xofs.push(sx as usize);
        xalpha.push([to_short((1.0 - fx) * COEF_SCALE), to_short(fx * COEF_SCALE)]);
    }
    // Vertical coefficients: unlike x, the weight is not reset at the borders, only the rows
    // are clamped (OpenCV's resizeGeneric_Invoker).
    let mut yofs = Vec::with_capacity(dh);
    let mut ybeta = Vec::with_capacity(dh);
    for dy in 0..dh {
        let fy = ((dy as f64 + 0.5) * scale_y - 0.5) as f32;
        let sy = cv_floor(fy);
        let fy = fy - sy as f32;
        yofs.push(sy);
        ybeta.push([to_short((1.0 - fy) * COEF_SCALE), to_short(fy * COEF_SCALE)]);
    }

    let hpass = |row: usize, out: &mut [i32]| {
        let s = &src[row * sw..(row + 1) * sw];
        for dx in 0..dw {
            let sx = xofs[dx];
            let [a0, a1] = xalpha[dx];
            let s1 = if sx + 1 < sw { s[sx + 1] } else { s[sx] };
            out[dx] = i32::from(s[sx]) * a0 + i32::from(s1) * a1;
        }
    };
    let clip_row = |y: i64| y.clamp(0, sh as i64 - 1) as usize;

    let mut dst = vec![0u8; dw * dh];
    let mut buf0 = vec![0i32; dw];
    let mut buf1 = vec![0i32; dw];
    let mut rows = [usize::MAX; 2];
    for dy in 0..dh {
        let r0 = clip_row(yofs[dy]);
        let r1 = clip_row(yofs[dy] + 1);
        // Reuse horizontally resized rows from the previous output row when possible.
        if rows[0] != r0 {
            if rows[1] == r0 {
                std::mem::swap(&mut buf0, &mut buf1);
                rows.swap(0, 1);
            } else {
                hpass(r0, &mut buf0);
                rows[0] = r0;
            }
        }
        if rows[1] != r1 {
            hpass(r1, &mut buf1);
            rows[1] = r1;
        }
        let [b0, b1] = ybeta[dy];
        let out = &mut dst[dy * dw..(dy + 1) * dw];
        for dx in 0..dw {
            let v = ((b0 * (buf0[dx] >> 4)) >> 16) + ((b1 * (buf1[dx] >> 4)) >> 16) + 2;
            out[dx] = (v >> 2).clamp(0, 255) as u8;
        }
    }
    dst
}

/// OpenCV's fast `INTER_AREA` for an exact 2x reduction: rounded mean of 2x2 blocks.
fn resize_area_fast_2x(src: &[u8], sw: usize, dw: usize, dh: usize) -> Vec<u8> {
    let mut dst = vec![0u8; dw * dh];
    for y in 0..dh {
        let r0 = &src[2 * y * sw..];
        let r1 = &src[(2 * y + 1) * sw..];
        for x in 0..dw {
            let s = u32::from(r0[2 * x])
                + u32::from(r0[2 * x + 1])
                + u32::from(r1[2 * x])
                + u32::from(r1[2 * x + 1]);
            dst[y * dw + x] = ((s + 2) >> 2) as u8;
        }
    }
    dst
}

/// A box in network-input coordinates after NMS (f32, as torch holds it).
#[derive(Clone, Copy, Debug)]
struct Cand {
    b: [f32; 4],
    score: f32,
    class: u32,
}

/// Ultralytics' `non_max_suppression` for one image: `data` is the (4 + nc, n) output.
fn nms_decode(data: &[f32], nc: usize, n: usize, conf: f64, iou: f64, max_det: usize) -> Vec<Cand> {
    let row = |k: usize| &data[k * n..(k + 1) * n];
    let mut cands: Vec<Cand> = Vec::new();
    for i in 0..n {
        // torch's max over classes: the first maximum.
        let (mut best, mut j) = (row(4)[i], 0usize);
        for c in 1..nc {
            let s = row(4 + c)[i];
            if s > best {
                best = s;
                j = c;
            }
        }
        // torch compares the f32 scores with the threshold cast to f32.
        if best > conf as f32 {
            let (xc, yc) = (row(0)[i], row(1)[i]);
            let (hw, hh) = (row(2)[i] / 2.0, row(3)[i] / 2.0);
            cands.push(Cand {
                b: [xc - hw, yc - hh, xc + hw, yc + hh],
                score: best,
                class: j as u32,
            });
        }
    }
    // torchvision.ops.nms sorts by score, descending, stably.
    cands.sort_by(|a, b| b.score.total_cmp(&a.score));
    cands.truncate(MAX_NMS);
    // Class-aware: offset boxes by class * max_wh (in f32, as torch does).
    let boxes: Vec<[f32; 4]> = cands
        .iter()
        .map(|c| {
            let off = c.class as f32 * MAX_WH;
            [c.b[0] + off, c.b[1] + off, c.b[2] + off, c.b[3] + off]
        })
        .collect();
    let areas: Vec<f32> = boxes
        .iter()
        .map(|b| (b[2] - b[0]) * (b[3] - b[1]))
        .collect();
    let mut suppressed = vec![false; cands.len()];
    let mut keep = Vec::new();
    for i in 0..cands.len() {
        if keep.len() >= max_det {
            break;
        }
        if suppressed[i] {
            continue;
        }
        keep.push(cands[i]);
        let bi = boxes[i];
        for j in i + 1..cands.len() {
            if suppressed[j] {
                continue;
            }
            let bj = boxes[j];
            let w = (bi[2].min(bj[2]) - bi[0].max(bj[0])).max(0.0);
            let h = (bi[3].min(bj[3]) - bi[1].max(bj[1])).max(0.0);
            let inter = w * h;
            let ovr = inter / (areas[i] + areas[j] - inter);
            if f64::from(ovr) > iou {
                suppressed[j] = true;
            }
        }
    }
    keep
}

/// Ultralytics' `scale_boxes(img1_shape, boxes, img0_shape)` then `clip_boxes`, in f32.
fn scale_boxes(kept: &[Cand], img1: (usize, usize), img0: (usize, usize)) -> Vec<Detection> {
    let (h1, w1) = (img1.0 as f64, img1.1 as f64);
    let (h0, w0) = (img0.0 as f64, img0.1 as f64);
    let gain = f64::min(h1 / h0, w1 / w0);
    let new_h = py_round(h0 * gain).max(1) as f64;
    let new_w = py_round(w0 * gain).max(1) as f64;
    let (gain_y, gain_x) = ((new_h / h0) as f32, (new_w / w0) as f32);
    let pad_x = py_round((w1 - new_w) / 2.0 - 0.1) as f32;
    let pad_y = py_round((h1 - new_h) / 2.0 - 0.1) as f32;
    let (wc, hc) = (w0 as f32, h0 as f32);
    kept.iter()
        .map(|c| {
            let x1 = ((c.b[0] - pad_x) / gain_x).clamp(0.0, wc);
            let y1 = ((c.b[1] - pad_y) / gain_y).clamp(0.0, hc);
            let x2 = ((c.b[2] - pad_x) / gain_x).clamp(0.0, wc);
            let y2 = ((c.b[3] - pad_y) / gain_y).clamp(0.0, hc);
            Detection {
                x1: f64::from(x1),
                y1: f64::from(y1),
                x2: f64::from(x2),
                y2: f64::from(y2),
                score: f64::from(c.score),
                class: c.class,
            }
        })
        .collect()
}

/// File name of the ONNX Runtime library inside a Python `onnxruntime/capi` folder.
fn is_ort_lib_name(name: &str) -> bool {
    let prefix = format!("{}onnxruntime", std::env::consts::DLL_PREFIX);
    name.starts_with(&prefix)
        && name.contains(std::env::consts::DLL_SUFFIX)
        && !name.contains("providers")
        && !name.contains("pybind")
}

/// The ONNX Runtime library inside an `onnxruntime` package folder, if any.
fn lib_in_package(pkg: &Path) -> Option<PathBuf> {
    let capi = pkg.join("capi");
    let mut found: Vec<PathBuf> = std::fs::read_dir(&capi)
        .ok()?
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_str().is_some_and(is_ort_lib_name))
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .collect();
    found.sort();
    found.into_iter().next()
}

/// `site-packages` folders under a prefix (a venv, `~/.local`).
fn site_packages_under(prefix: &Path) -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    for lib in ["lib", "lib64"] {
        if let Ok(entries) = std::fs::read_dir(prefix.join(lib)) {
            let mut v: Vec<PathBuf> = entries
                .filter_map(|e| e.ok())
                .filter(|e| {
                    e.file_name()
                        .to_str()
                        .is_some_and(|n| n.starts_with("python"))
                })
                .map(|e| e.path().join("site-packages"))
                .filter(|p| p.is_dir())
                .collect();
            v.sort();
            dirs.extend(v);
        }
    }
    let win = prefix.join("Lib").join("site-packages");
    if win.is_dir() {
        dirs.push(win);
    }
    dirs
}

/// Where to look, for [`locate_onnxruntime`].
struct OrtSearch {
    dylib_env: Option<std::ffi::OsString>,
    pythons: Vec<PathBuf>,
    prefixes: Vec<PathBuf>,
}

fn locate_onnxruntime(search: &OrtSearch) -> Result<PathBuf, YoloError> {
    if let Some(p) = search.dylib_env.as_ref().filter(|p| !p.is_empty()) {
        let p = PathBuf::from(p);
        return if p.is_file() {
            Ok(p)
        } else {
            Err(YoloError::OrtDylibPathMissing(p))
        };
    }
    let mut searched = vec!["ORT_DYLIB_PATH (unset)".to_string()];
    const IMPORT: &str = "import onnxruntime, os; print(os.path.dirname(onnxruntime.__file__))";
    const SITES: &str = "import site, sys\nfor p in site.getsitepackages() + [site.getusersitepackages()] + sys.path: print(p)";
    let mut site_dirs: Vec<PathBuf> = Vec::new();
    for py in &search.pythons {
        searched.push(format!("`{} -c 'import onnxruntime'`", py.display()));
        if let Some(lines) = python::lines(py, IMPORT)
            && let Some(dir) = lines.last()
            && let Some(lib) = lib_in_package(Path::new(dir))
        {
            return Ok(lib);
        }
        if let Some(lines) = python::lines(py, SITES) {
            site_dirs.extend(lines.into_iter().map(PathBuf::from));
        }
    }
    let mut dirs: Vec<PathBuf> = search
        .prefixes
        .iter()
        .flat_map(|p| site_packages_under(p))
        .collect();
    dirs.extend(site_dirs);
    for dir in &dirs {
        if let Some(lib) = lib_in_package(&dir.join("onnxruntime")) {
            return Ok(lib);
        }
    }
    let prefixes: Vec<String> = search
        .prefixes
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    searched.push(format!(
        "site-packages under {}",
        if prefixes.is_empty() {
            "-".into()
        } else {
            prefixes.join(", ")
        }
    ));
    if !dirs.is_empty() {
        searched.push(format!("{} interpreter site dirs", dirs.len()));
    }
    Err(YoloError::OnnxRuntimeNotFound {
        searched: searched.join("; "),
    })
}

/// Where the ONNX Runtime shared library is: `$ORT_DYLIB_PATH`, else the `onnxruntime` Python
/// package's `capi/libonnxruntime.so*`, found via `python3 -c 'import onnxruntime, os;
/// print(os.path.dirname(onnxruntime.__file__))'` or by scanning `site-packages` under `./.venv`,
/// `$VIRTUAL_ENV`, `~/.local` and the interpreter's site dirs. The error tells the user to run the
/// project's setup (`pip install onnxruntime`) when absent.
pub fn find_onnxruntime() -> Result<PathBuf, YoloError> {
    let mut prefixes = vec![PathBuf::from(".venv")];
    if let Some(v) = std::env::var_os("VIRTUAL_ENV").filter(|v| !v.is_empty()) {
        prefixes.push(PathBuf::from(v));
    }
    if let Some(home) = std::env::var_os("HOME").filter(|v| !v.is_empty()) {
        prefixes.push(PathBuf::from(home).join(".local"));
    }
    let mut pythons = vec![PathBuf::from(".venv/bin/python3")];
    pythons.retain(|p| p.is_file());
    pythons.push(PathBuf::from("python3"));
    locate_onnxruntime(&OrtSearch {
        dylib_env: std::env::var_os("ORT_DYLIB_PATH"),
        pythons,
        prefixes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_runtime_error_says_how_to_install() {
        let dir = std::env::temp_dir().join(format!("soig-yolo-no-ort-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let search = OrtSearch {
            dylib_env: None,
            pythons: vec![dir.join("no-such-python")],
            prefixes: vec![dir.join(".venv")],
        };
        let err = locate_onnxruntime(&search).unwrap_err();
        assert!(
            matches!(err, YoloError::OnnxRuntimeNotFound { .. }),
            "{err:?}"
        );
        let msg = err.to_string();
        assert!(msg.contains("pip install onnxruntime"), "{msg}");
        assert!(msg.contains("ORT_DYLIB_PATH"), "{msg}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_dylib_env_is_reported() {
        let search = OrtSearch {
            dylib_env: Some("/nonexistent/libonnxruntime.so".into()),
            pythons: vec![],
            prefixes: vec![],
        };
        let err = locate_onnxruntime(&search).unwrap_err();
        assert_eq!(
            err,
            YoloError::OrtDylibPathMissing("/nonexistent/libonnxruntime.so".into())
        );
    }

    #[test]
    fn finds_library_in_a_venv_layout() {
        let dir = std::env::temp_dir().join(format!("soig-yolo-venv-{}", std::process::id()));
        let capi = dir.join("lib/python3.11/site-packages/onnxruntime/capi");
        std::fs::create_dir_all(&capi).unwrap();
        for name in [
            "libonnxruntime_providers_shared.so",
            "onnxruntime_pybind11_state.so",
            "libonnxruntime.so.1.32.0",
        ] {
            std::fs::write(capi.join(name), b"").unwrap();
        }
        let search = OrtSearch {
            dylib_env: None,
            pythons: vec![],
            prefixes: vec![dir.clone()],
        };
        let found = locate_onnxruntime(&search).unwrap();
        if cfg!(target_os = "linux") {
            assert_eq!(found, capi.join("libonnxruntime.so.1.32.0"));
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn python_round_is_half_even() {
        assert_eq!(py_round(0.5), 0);
        assert_eq!(py_round(1.5), 2);
        assert_eq!(py_round(2.5), 2);
        assert_eq!(py_round(-0.1), 0);
        assert_eq!(py_round(426.666), 427);
    }

    #[test]
    fn letterbox_geometry_matches_ultralytics() {
        // 300x200 -> r = 640/300: 640x427, dh = 213 -> top 106, bottom 107.
        let img = vec![7u8; 300 * 200];
        let lb = letterbox_gray(&img, 300, 200, 640, 640, None);
        assert_eq!(
            (
                lb.width,
                lb.height,
                lb.new_width,
                lb.new_height,
                lb.left,
                lb.top
            ),
            (640, 640, 640, 427, 0, 106)
        );
        assert_eq!(lb.data[0], PAD_VALUE);
        assert_eq!(lb.data[106 * 640], 7);
        assert_eq!(lb.data[(106 + 427) * 640], PAD_VALUE);
        // auto: pad only to a multiple of 32 -> 213 % 32 = 21 -> 10 top, 11 bottom.
        let lb = letterbox_gray(&img, 300, 200, 640, 640, Some(32));
        assert_eq!((lb.width, lb.height, lb.top), (640, 448, 10));
    }

    #[test]
    fn constant_image_resizes_to_constant() {
        for (sw, sh, dw, dh) in [
            (1024, 1024, 640, 640),
            (300, 200, 640, 427),
            (1280, 960, 640, 480),
            (7, 3, 640, 274),
        ] {
            for v in [0u8, 1, 114, 254, 255] {
                let out = resize_linear_u8(&vec![v; sw * sh], sw, sh, dw, dh);
                assert!(
                    out.iter().all(|&p| p == v),
                    "{sw}x{sh}->{dw}x{dh} value {v}"
                );
            }
        }
    }

    #[test]
    fn nms_is_class_aware_and_ordered() {
        // Three anchors, two classes: anchor 0 and 1 overlap (same class 0), anchor 2 overlaps
        // anchor 0 but is class 1.
        let n = 3;
        let xc = [100.0f32, 102.0, 100.0];
        let yc = [100.0f32, 100.0, 100.0];
        let w = [50.0f32, 50.0, 50.0];
        let h = [50.0f32, 50.0, 50.0];
        let c0 = [0.9f32, 0.8, 0.1];
        let c1 = [0.0f32, 0.0, 0.7];
        let data: Vec<f32> = [xc, yc, w, h, c0, c1].concat();
        let kept = nms_decode(&data, 2, n, 0.25, 0.5, 300);
        let got: Vec<(f32, u32)> = kept.iter().map(|c| (c.score, c.class)).collect();
        assert_eq!(got, vec![(0.9, 0), (0.7, 1)]);
        let kept = nms_decode(&data, 2, n, 0.25, 0.5, 1);
        assert_eq!(kept.len(), 1);
        let kept = nms_decode(&data, 2, n, 0.95, 0.5, 300);
        assert!(kept.is_empty());
    }

    #[test]
    fn anchors_of_yolov8() {
        assert_eq!(anchor_count(640, 640), 8400);
        assert_eq!(anchor_count(1024, 1024), 21504);
    }
}
