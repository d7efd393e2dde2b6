//! Letterboxing as Ultralytics' `LetterBox`, with the resize a bit-exact port of OpenCV's 8-bit
//! `cv2.resize(..., INTER_LINEAR)` (fixed-point weights, `INTER_AREA` for an exact 2x reduction)
//! and Python's rounding of sizes and padding, so that the network sees the same input bytes.

/// Ultralytics' letterbox padding value.
const PAD_VALUE: u8 = 114;

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
pub(super) fn py_round(x: f64) -> i64 {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
