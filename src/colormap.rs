//! The viridis colormap of every false-colour map (`compare::heatmap`'s
//! RelMSE, FLIP and density maps, the colour bars of `figure.png`, the
//! legends of the comparison page, `crate::viewer`): dark purple → blue →
//! green → yellow, piecewise linear through 9 of its published control
//! points ([`VIRIDIS`]); NaN is magenta.

/// Viridis at t = 0, 1/8, …, 1 (sRGB, 0..=255).
pub const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 81, 139],
    [44, 113, 142],
    [33, 144, 141],
    [39, 173, 129],
    [92, 200, 99],
    [170, 220, 50],
    [253, 231, 37],
];

/// The colour of NaN (a non-finite pixel of a render).
pub const NAN_COLOUR: [u8; 3] = [255, 0, 255];

/// Viridis at t ∈ [0, 1] (clamped); NaN → magenta.
pub fn viridis(t: f32) -> [u8; 3] {
    if t.is_nan() {
        return NAN_COLOUR;
    }
    let x = t.clamp(0.0, 1.0) * 8.0;
    let i = (x.floor() as usize).min(7);
    let f = x - i as f32;
    std::array::from_fn(|c| {
        let (a, b) = (VIRIDIS[i][c] as f32, VIRIDIS[i + 1][c] as f32);
        (a + f * (b - a)).round() as u8
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_ends_and_nan() {
        assert_eq!(viridis(0.0), VIRIDIS[0]);
        assert_eq!(viridis(1.0), VIRIDIS[8]);
        assert_eq!(viridis(-3.0), VIRIDIS[0]);
        assert_eq!(viridis(0.5), VIRIDIS[4]);
        assert_eq!(viridis(f32::NAN), NAN_COLOUR);
    }
}
