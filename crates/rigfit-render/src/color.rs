//! Colours: a palette of distinct hues, and one colour per chain of bones.

use rigfit_core::{JointKind, Skeleton};

/// An opaque sRGB colour.
/// The default is black.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Color {
    pub r: u8,
    pub g: u8,
    pub b: u8,
}

impl Color {
    pub const fn rgb(r: u8, g: u8, b: u8) -> Self {
        Self { r, g, b }
    }

    /// This colour with its brightness scaled by `factor` (0 = black, 1 = unchanged).
    pub fn shaded(self, factor: f32) -> Self {
        let f = factor.clamp(0.0, 1.0);
        let s = |c: u8| (c as f32 * f).round() as u8;
        Self::rgb(s(self.r), s(self.g), s(self.b))
    }

    /// The colour `t` of the way from `self` to `other`.
    pub fn mix(self, other: Color, t: f32) -> Self {
        let t = t.clamp(0.0, 1.0);
        let m = |a: u8, b: u8| (a as f32 + (b as f32 - a as f32) * t).round() as u8;
        Self::rgb(m(self.r, other.r), m(self.g, other.g), m(self.b, other.b))
    }

    pub(crate) fn to_skia(self) -> tiny_skia::Color {
        tiny_skia::Color::from_rgba8(self.r, self.g, self.b, 255)
    }
}

/// The background of every picture.
pub const BACKGROUND: Color = Color::rgb(255, 255, 255);
/// Text, axes and outlines.
pub const INK: Color = Color::rgb(40, 40, 40);
/// Faint lines: tile borders, plot grids.
pub const GRID: Color = Color::rgb(225, 225, 225);
/// Flat-shaded meshes, fully lit.
pub const MESH: Color = Color::rgb(190, 200, 215);
/// Points the solver kept.
pub const INLIER: Color = Color::rgb(40, 110, 190);
/// Points the solver rejected as outliers.
pub const OUTLIER: Color = Color::rgb(230, 60, 40);
/// Strokes matched to no bone (strays).
pub const STRAY: Color = Color::rgb(150, 150, 150);

/// Ten hues that tell apart well (the "tab10" palette of matplotlib / d3).
pub const PALETTE: [Color; 10] = [
    Color::rgb(31, 119, 180),
    Color::rgb(255, 127, 14),
    Color::rgb(44, 160, 44),
    Color::rgb(214, 39, 40),
    Color::rgb(148, 103, 189),
    Color::rgb(140, 86, 75),
    Color::rgb(227, 119, 194),
    Color::rgb(127, 127, 127),
    Color::rgb(188, 189, 34),
    Color::rgb(23, 190, 207),
];

/// The `i`-th palette colour (cycling).
pub fn palette(i: usize) -> Color {
    PALETTE[i % PALETTE.len()]
}

/// One colour per joint: joints in the same chain (a run of single-child joints that starts
/// at a root or below a branching joint) share a palette colour, and neighbouring chains
/// differ. The bone from a joint's parent to the joint is drawn in the joint's colour, and a
/// bone named by the joint that turns it (as in `PoseResult::stroke_bones`) takes that
/// joint's colour.
pub fn chain_colors(skeleton: &Skeleton) -> Vec<Color> {
    let mut chain_of = vec![0usize; skeleton.len()];
    let mut chains = 0usize;
    for j in 0..skeleton.len() {
        let joint = skeleton.joint(j);
        let continues = joint.parent.is_some_and(|p| {
            skeleton.joint(p).kind != JointKind::Helper
                && skeleton
                    .children(p)
                    .iter()
                    .filter(|&&c| !skeleton.joint(c).kind.is_tip())
                    .count()
                    <= 1
        });
        chain_of[j] = match joint.parent {
            Some(p) if continues => chain_of[p],
            _ => {
                chains += 1;
                chains - 1
            }
        };
    }
    chain_of.into_iter().map(palette).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_limb_shares_one_colour_and_limbs_differ() {
        let rig = rigfit_core::humanoid::humanoid();
        let s = &rig.skeleton;
        let colors = chain_colors(s);
        let of = |name: &str| colors[s.find(name).expect("humanoid joint")];
        assert_eq!(of("LeftArm"), of("LeftForeArm"));
        assert_eq!(of("LeftForeArm"), of("LeftHand"));
        assert_ne!(of("LeftArm"), of("RightArm"));
        assert_ne!(of("LeftUpLeg"), of("RightUpLeg"));
        assert_ne!(of("LeftUpLeg"), of("LeftArm"));
    }

    #[test]
    fn shading_and_mixing_stay_in_range() {
        let c = Color::rgb(200, 100, 50);
        assert_eq!(c.shaded(1.0), c);
        assert_eq!(c.shaded(0.0), Color::rgb(0, 0, 0));
        assert_eq!(c.shaded(7.0), c);
        assert_eq!(c.mix(BACKGROUND, 1.0), BACKGROUND);
        assert_eq!(c.mix(BACKGROUND, -1.0), c);
    }
}
