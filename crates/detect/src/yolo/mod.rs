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

mod postprocess;
mod preprocess;
mod runtime;

use std::path::{Path, PathBuf};

use ort::session::Session;
use ort::session::builder::GraphOptimizationLevel;
use ort::value::{TensorElementType, TensorRef, ValueType};

use super::Detection;
use postprocess::{nms_decode, scale_boxes};
pub use preprocess::{Letterboxed, letterbox_gray, resize_linear_u8};
pub use runtime::find_onnxruntime;
use runtime::ort_environment;

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

fn not_yolo(path: &Path, message: impl Into<String>) -> YoloError {
    YoloError::NotYolov8 {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// The shape of the model's float32 tensor `what` (input or output), or why it is not YOLOv8.
fn float32_shape(model: &Path, dtype: &ValueType, what: &str) -> Result<Vec<i64>, YoloError> {
    let ValueType::Tensor { ty, shape, .. } = dtype else {
        return Err(not_yolo(model, format!("the {what} is not a tensor")));
    };
    if *ty != TensorElementType::Float32 {
        return Err(not_yolo(
            model,
            format!("{what} element type is {ty:?}, expected float32"),
        ));
    }
    Ok(shape.iter().copied().collect())
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
        let ishape = float32_shape(model, inputs[0].dtype(), "input")?;
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
        let oshape = float32_shape(model, outputs[0].dtype(), "output")?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anchors_of_yolov8() {
        assert_eq!(anchor_count(640, 640), 8400);
        assert_eq!(anchor_count(1024, 1024), 21504);
    }
}
