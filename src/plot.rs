//! Drawing shared by the figures of the report and of the study: the embedded font, and a PNG
//! canvas for plotters charts.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

/// The colours of the figures' series, in order: red, blue, green, then purple and orange
/// for the study's longer lists. A figure with at most three series cycles the first three
/// (`&PALETTE[..3]`), as it always has.
pub const PALETTE: [RGBColor; 5] = [
    RGBColor(200, 30, 30),
    RGBColor(30, 90, 200),
    RGBColor(30, 150, 60),
    RGBColor(150, 60, 180),
    RGBColor(220, 130, 0),
];

/// The embedded sans-serif font of every plot (plotters has no system fonts here).
pub fn register_font() {
    static FONT: std::sync::Once = std::sync::Once::new();
    FONT.call_once(|| {
        let _ = plotters::style::register_font(
            "sans-serif",
            plotters::style::FontStyle::Normal,
            include_bytes!("../assets/DejaVuSans.ttf"),
        );
    });
}

/// A `w` x `h` chart drawn by `draw` on white, written as an RGB PNG at `path` (atomically).
pub fn png(
    path: &Path,
    (w, h): (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    register_font();
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        draw(&root)?;
        root.present()?;
    }
    let img = image::RgbImage::from_raw(w, h, buf).expect("buffer size");
    crate::store::fs::write(path, rgb_png(&img)?)
}

/// The chart's series labels at `position`, on a translucent white box with a black border.
pub fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(position)
        .draw()?;
    Ok(())
}

/// The PNG of `img`, the bytes `RgbImage::save` writes (the PNG encoder's defaults).
pub fn rgb_png(img: &image::RgbImage) -> anyhow::Result<Vec<u8>> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png)?;
    Ok(bytes.into_inner())
}
