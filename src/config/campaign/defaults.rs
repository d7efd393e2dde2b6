//! The paper's values (with the corrections of `physics.md`); one place lists every knob.

use super::Stage;

pub fn images() -> u32 {
    4000
}
pub fn stages() -> Vec<Stage> {
    vec![Stage::Render, Stage::Enhance, Stage::Dataset]
}
pub fn window_start() -> String {
    "2022-01-01T00:00:00 UTC".into()
}
pub fn window_end() -> String {
    "2023-01-01T06:00:00 UTC".into()
}
pub fn exposure_min() -> f64 {
    2.0
}
pub fn exposure_max() -> f64 {
    8.0
}
pub fn placement_fraction() -> f64 {
    0.8
}
pub fn image_px() -> u32 {
    1024
}
pub fn fov_radius() -> f64 {
    0.1
}
pub fn zero_point() -> f64 {
    22.26
}
pub fn gain() -> f64 {
    1.6
}
pub fn background_min() -> f64 {
    190.0
}
pub fn background_max() -> f64 {
    210.0
}
pub fn background_exposure() -> f64 {
    5.0
}
pub fn bias_min() -> f64 {
    2.0
}
pub fn bias_max() -> f64 {
    3.0
}
pub fn mag_limit() -> f64 {
    16.5
}
pub fn psf_sigma() -> f64 {
    1.0
}
pub fn jitter() -> f64 {
    0.0002
}
pub fn catalog_epoch() -> f64 {
    2016.0
}
pub fn star_cone() -> f64 {
    0.15
}
pub fn rcs_mean() -> f64 {
    0.956
}
pub fn rcs_std() -> f64 {
    2.291
}
pub fn albedo() -> f64 {
    1.0
}
pub fn tumble_period_min() -> f64 {
    1.0
}
pub fn tumble_period_max() -> f64 {
    20.0
}
pub fn tumble_amplitude() -> f64 {
    0.5
}
pub fn earth_min() -> f64 {
    105.0
}
pub fn sun_min() -> f64 {
    20.0
}
pub fn moon_min() -> f64 {
    15.0
}
pub fn clearance() -> f64 {
    100.0
}
pub fn brightest_star() -> f64 {
    6.0
}
pub fn snr_fixed() -> f64 {
    0.15
}
pub fn snr_survey() -> f64 {
    0.035
}
pub fn max_attempts() -> u32 {
    10_000
}
pub fn trajectory_samples() -> u32 {
    2000
}
pub fn merge_threshold() -> u64 {
    100_000
}
pub fn merge_factor() -> u32 {
    5
}
pub fn jitter_steps() -> u32 {
    2000
}
pub fn yes() -> bool {
    true
}
pub fn clahe_clip() -> f64 {
    2.0
}
pub fn clahe_tiles() -> [u32; 2] {
    [8, 8]
}
pub fn gamma() -> f64 {
    0.7
}
pub fn pad_px() -> u32 {
    32
}
pub fn split_train() -> f64 {
    0.7
}
pub fn split_val() -> f64 {
    0.2
}
pub fn split_test() -> f64 {
    0.1
}
pub fn train_model() -> String {
    "yolov8n.yaml".into()
}
pub fn train_epochs() -> u32 {
    200
}
pub fn train_optimizer() -> String {
    "auto".into()
}
pub fn train_device() -> String {
    "auto".into()
}
pub fn train_workers() -> u32 {
    2
}
pub fn train_patience() -> u32 {
    100
}
// The YOLO thresholds live with the detector, which must not depend on the campaign.
pub fn detect_conf() -> f64 {
    crate::detect::yolo::DEFAULT_CONF
}
pub fn detect_iou() -> f64 {
    crate::detect::yolo::DEFAULT_IOU
}
pub fn max_det() -> u32 {
    crate::detect::yolo::DEFAULT_MAX_DET
}
// The physical noise model's detector: TELEDYNE CCD47-20 (13 um pixels, 100,000 e- full well,
// a few e- read noise), a 16-bit ADC.
pub fn read_noise() -> f64 {
    5.0
}
pub fn bias_level() -> f64 {
    100.0
}
pub fn full_well() -> f64 {
    100_000.0
}
pub fn adc_max() -> f64 {
    65_535.0
}
pub fn hot_pixel_dark() -> f64 {
    50.0
}
pub fn pixel_size() -> f64 {
    13.0
}

/// `background.share`: every image on a frame.
pub fn share() -> f64 {
    1.0
}
pub fn is_share(v: &f64) -> bool {
    *v == 1.0
}
