//! The passes of a frame, by name: one enum for the timings, the reports, the bench's CSV columns and
//! the editor's Stats panel.

use std::fmt;

/// One GPU pass. The variants are in frame order: [`Pass::ALL`] is the order they run in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Pass {
    /// What the surfaces' lighting needs of the nearest surface, and the eye distance per pixel.
    Surface,
    /// The directional shadow map's rectangle, fitted to the view segments.
    ShadowFit,
    /// Distance from the light to the nearest surface (cube or orthographic map).
    ShadowMap,
    /// The sun's shadow on each visible surface point, tested against the triangles.
    ExactShadows,
    /// The bins' z range fitted to the visible depth.
    Ranges,
    /// The triangles that can shadow a visible point, and Voxelize's work list.
    Cull,
    /// The geometry bits of the epipolar grid.
    Voxelize,
    /// The prefix OR along the rays: the shadow volume.
    Scan,
    /// The first-hit volume's bounds per word of bins (in place of Scan in a first-hit frame).
    HitBounds,
    /// The cumulative unshadowed in-scattering (point lights).
    ScatterTable,
    /// Per-pixel single scattering over the lit runs.
    Integrate,
    /// The baseline: ray marching against the shadow map.
    Raymarch,
    /// Surface radiance attenuated along the view ray, plus the in-scattering.
    Composite,
    /// The farthest first hit over blocks of the directional shadow map, for the next frames'
    /// Cull (hidden triangles), after a frame whose map's inputs changed.
    ShadowPyramid,
}

impl Pass {
    /// The passes before the volume's integration (Integrate or Raymarch): a frame whose inputs to
    /// them did not change takes their results from the last frame (`Renderer::reuse_unchanged`).
    pub const BEFORE_VOLUME: [Pass; 9] = [
        Pass::Surface,
        Pass::ShadowFit,
        Pass::ShadowMap,
        Pass::ExactShadows,
        Pass::Ranges,
        Pass::Cull,
        Pass::Voxelize,
        Pass::Scan,
        Pass::HitBounds,
    ];
    /// Every pass, in frame order.
    pub const ALL: [Pass; 14] = [
        Pass::Surface,
        Pass::ShadowFit,
        Pass::ShadowMap,
        Pass::ExactShadows,
        Pass::Ranges,
        Pass::Cull,
        Pass::Voxelize,
        Pass::Scan,
        Pass::HitBounds,
        Pass::ScatterTable,
        Pass::Integrate,
        Pass::Raymarch,
        Pass::Composite,
        Pass::ShadowPyramid,
    ];

    /// The name in reports, JSON keys and CSV columns (`shadow_map`).
    pub fn label(self) -> &'static str {
        match self {
            Pass::Surface => "surface",
            Pass::ShadowFit => "shadow_fit",
            Pass::ShadowMap => "shadow_map",
            Pass::ExactShadows => "exact_shadows",
            Pass::Ranges => "ranges",
            Pass::ShadowPyramid => "shadow_pyramid",
            Pass::Cull => "cull",
            Pass::Voxelize => "voxelize",
            Pass::Scan => "scan",
            Pass::HitBounds => "hit_bounds",
            Pass::ScatterTable => "scatter_table",
            Pass::Integrate => "integrate",
            Pass::Raymarch => "raymarch",
            Pass::Composite => "composite",
        }
    }

    /// The pass of a [`Pass::label`].
    pub fn from_label(label: &str) -> Option<Pass> {
        Pass::ALL.into_iter().find(|p| p.label() == label)
    }

    /// Whether the pass finishes the shadow volume (Scan for the bits, HitBounds for the first
    /// hits): a frame that reused it holds the last frame's volume.
    pub fn makes_volume(self) -> bool {
        matches!(self, Pass::Scan | Pass::HitBounds)
    }

    /// Whether the pass belongs to the voxel pipeline (skipped when nothing scatters).
    pub fn is_voxel(self) -> bool {
        matches!(
            self,
            Pass::Ranges
                | Pass::ShadowPyramid
                | Pass::Cull
                | Pass::Voxelize
                | Pass::Scan
                | Pass::HitBounds
                | Pass::ScatterTable
        )
    }
}

impl fmt::Display for Pass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.label())
    }
}

/// One pass's GPU time in a frame (the sum when it ran more than once, e.g. per chunk of triangles).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PassTiming {
    pub pass: Pass,
    pub ms: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_round_trip_and_follow_frame_order() {
        for p in Pass::ALL {
            assert_eq!(Pass::from_label(p.label()), Some(p));
        }
        let mut sorted = Pass::ALL;
        sorted.sort();
        assert_eq!(sorted, Pass::ALL, "the enum's order is the frame order");
        assert_eq!(Pass::from_label("nope"), None);
    }
}
