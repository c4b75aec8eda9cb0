//! # epivox
//!
//! Light shafts and volumetric shadows in homogeneous participating media with *Voxelized Epipolar
//! Shadow Volumes* (Wyman 2011), an exact CPU reference beside it, and the tools around both.
//!
//! Data flows one way:
//!
//! ```text
//! scene file / mesh / built-in ──► Scene (meshes, camera, light, medium, grid)
//!                                    │
//!            params (ranges, docs) ──┤
//!                                    ▼
//!   render::Renderer: ShadowMap ─► Surface ─► Ranges ─► Cull ─► Voxelize ─► Scan ─► ScatterTable ─► Integrate ─► Composite
//!                                    │          (or Raymarch, the baseline, after Surface)          │
//!                                    ▼                                                               ▼
//!                      reference::render (f64, CPU)                                     Image (linear RGB) ─► PNG / EXR
//!                                    └──────────────► metrics::compare ◄────────────────────────────┘
//! ```
//!
//! See `docs/architecture.md` for the longer version and `../shared/DESIGN.md` for the mathematics.

pub mod bench;
pub mod check;
pub mod editor;
pub mod epipolar;
pub mod fsx;
pub mod gpu;
pub mod image;
pub mod metrics;
pub mod params;
pub mod preset;
pub mod reference;
pub mod render;
pub mod scene;

pub use image::Image;
pub use params::{BinSpacing, Grid, Light, Medium, Phase};
pub use scene::{Camera, Mesh, Scene};
