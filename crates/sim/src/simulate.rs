//! One image, in memory: the scene draw, photon mapping and detector, and (when the
//! experiment has an 8-bit product) the final frame, the label box in it and the enhanced
//! image. A pure function of (experiment, inputs, image index): every random draw comes from
//! the image's own streams (`rng::stream(seed, index, purpose)`), so images can be made in
//! any order, on any number of threads or machines. Nothing here touches the disk (the
//! pipeline's writer does) or reads the campaign file (the `experiment` layer builds the
//! [`Experiment`]).

use std::time::Instant;

use crate::render::{self, Exposure};
use crate::scene::{self, Inputs, NoScene, Scene};
use crate::sensor::Sensor;
use soig_base::rng::{PixelPurpose, PixelRng, object_pixel_stream, pixel_stream};
use soig_image::enhance::{self, Gray8};
use soig_image::geometry::{self, BoxPx, Fill, Frame, FrameKind, LABEL_SHARE};

/// Everything one image needs besides its inputs and index.
#[derive(Clone, Debug, PartialEq)]
pub struct Experiment {
    /// The campaign seed: every random stream of image i is `rng::stream(seed, i, purpose)`.
    pub seed: u64,
    pub sensor: Sensor,
    pub scene: scene::Spec,
    pub render: render::Settings,
    /// The final frame of the PNGs and labels, and the enhancement; None when the campaign
    /// stops at the FITS (no `enhance` stage).
    pub product: Option<Product>,
}

/// The 8-bit product of an image: its frame and enhancement.
#[derive(Clone, Debug, PartialEq)]
pub struct Product {
    pub frame: FrameKind,
    /// Border of the padded frame, pixels.
    pub pad_px: usize,
    pub enhance: enhance::Settings,
}

/// Everything one image produces.
pub struct ImageProducts {
    pub scene: Scene,
    /// The rendered exposure; its truth holds the final frame and label box when there is a
    /// product.
    pub exposure: Exposure,
    pub product: Option<FinalImage>,
}

/// The 8-bit image for the detector, in its final frame, with its label.
pub struct FinalImage {
    pub frame: Frame,
    pub png: Gray8,
    /// The label boxes in the final frame, one per object shown on which a debris photon
    /// landed, in the objects' order.
    pub labels: Vec<BoxPx>,
    /// Frame and enhancement time, seconds (the report's FITS -> PNG conversion time).
    pub seconds: f64,
}

/// Draw, render and (with a product) frame and enhance image `index`.
pub fn image(x: &Experiment, inputs: &Inputs, index: u64) -> Result<ImageProducts, NoScene> {
    let seed = x.seed;
    let scene = scene::draw(&x.scene, &x.sensor, inputs, seed, index)?;
    // `render::render`'s streams and order, with each placed object's photons on its own.
    let photons = &mut pixel_stream(seed, index, PixelPurpose::Photons);
    let jitter = render::Jitter::of_scene(&x.sensor, &x.render, &scene, photons);
    let mut exposure = render::render_with_jitter(
        &x.sensor,
        &x.render,
        &scene,
        inputs.frame(scene.exposure.background),
        &jitter,
        photons,
        &mut pixel_stream(seed, index, PixelPurpose::Noise),
        Some(&|k| object_pixel_stream(seed, index, k, PixelPurpose::ObjectPhotons)),
    );
    let product = x.product.as_ref().map(|p| {
        let started = Instant::now();
        let (w, h) = (exposure.width, exposure.height);
        let trail_angle_deg = scene.exposure.pointing.trail_angle_deg().unwrap_or(0.0);
        let frame = Frame::new(p.frame, w, h, p.pad_px, trail_angle_deg);
        // The debris alone is warped like the image, so the label is the tight box of the
        // rendered streak in the final frame.
        let mut rng = pixel_stream(seed, index, PixelPurpose::Enhance);
        let adu = geometry::warp(&exposure.adu, w, h, &frame, Fill::SkyNoise(&mut rng));
        // In the original frame that is the box the renderer already found (the same
        // computation on the same pixels): not built again (7.5 ms a 1024 px image).
        let final_box = |original: Option<BoxPx>, debris: &dyn Fn() -> Vec<f32>| {
            if frame.is_identity() {
                original
            } else {
                let debris = geometry::warp::<PixelRng>(&debris(), w, h, &frame, Fill::Zero);
                geometry::flux_box(&debris, frame.width, frame.height, LABEL_SHARE)
            }
        };
        let labels = match &mut exposure.objects {
            Some(objects) => objects
                .iter_mut()
                .filter_map(|o| {
                    let label = final_box(o.truth.label_box_px, &|| o.debris.to_image(w, h));
                    o.truth.frame = Some(frame.clone());
                    o.truth.label_box_final_px = label;
                    label
                })
                .collect(),
            None => {
                let electrons = &exposure.debris_electrons;
                let label = final_box(exposure.truth.label_box_px, &|| {
                    electrons.iter().map(|&v| v as f32).collect()
                });
                exposure.truth.label_box_final_px = label;
                label.into_iter().collect()
            }
        };
        exposure.truth.frame = Some(frame.clone());
        let png = enhance::enhance(&adu, frame.width, frame.height, &p.enhance);
        FinalImage {
            frame,
            png,
            labels,
            seconds: started.elapsed().as_secs_f64(),
        }
    });
    Ok(ImageProducts {
        scene,
        exposure,
        product,
    })
}
