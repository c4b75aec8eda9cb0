//! Shader variants (DESIGN section 6, "passes"): a pass whose shader depends on the light type, the
//! phase function, whether the medium is grey, the grid's axes or (Integrate) whether its rays start
//! on four words builds one pipeline per combination a frame actually uses, with the WGSL
//! pipeline-overridable constants `POINT_LIGHT`, `PHASE`, `GREY_MEDIUM`, `CARTESIAN`, `COSINE_BINS`,
//! `QUAD_RAYS`, `GRID_SHADOWS`, `WHOLE_RAY_ITEMS`, `EXACT_SHADOWS` and `FIRST_HITS` (`shaders/common.wgsl`) set. The shader
//! compiler then folds the branches on them away when it builds the pipeline, instead of every
//! pixel taking them at run time. (On llvmpipe a branch on a value read from a buffer runs both
//! sides for every pixel: a grey-medium test made at run time saved nothing, the same test as a
//! constant a third of Integrate on the classroom; the Cartesian grid's and the cosine bins'
//! branches, never taken in an epipolar frame of a sun, cost Voxelize half and Integrate a quarter
//! of their time; Integrate's surface shadows from the grid, behind a run-time flag that a frame
//! with the map never set, still cost that frame's Integrate 12%, session 27; and the other way
//! round, Composite's shadow-map lookups and Cull's hidden-triangle test, which a grid-shadow frame
//! never takes, cost its Composite a third and its Cull a tenth, session 29.)
//!
//! Pipelines are built on first use ([`VariantPipelines::prepare`], called by
//! `Renderer::render_frame` before it records) and kept, so switching the phase function in the
//! editor costs one pipeline build per pass the first time and nothing after.

use crate::params::Phase;
use std::fmt;

/// What a pipeline is specialised to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Variant {
    /// Point light (else directional). For the Cartesian grid this is always `false`.
    pub point_light: bool,
    /// [`Phase::id`].
    pub phase: u32,
    /// The medium's extinction is the same in R, G and B: transmittances take one channel's
    /// exponential.
    pub grey: bool,
    /// The grid is the paper's screen-space Cartesian one ([`super::Method::Cartesian`]).
    pub cartesian: bool,
    /// The bins are uniform in `cos psi` ([`crate::params::BinSpacing::UniformCosine`], point
    /// lights only), else uniform in `psi` or distance.
    pub cosine_bins: bool,
    /// Every grid ray starts on four 32-bit words ([`crate::params::Grid::quad_rays`]): Integrate
    /// reads the grid as `vec4<u32>`. Only Integrate's pipelines depend on it.
    pub quad_rays: bool,
    /// The frame's surface shadows come from the shadow volume ([`super::Renderer::surface_shadows`]: grid):
    /// Integrate computes them, and the frame draws no shadow map. Integrate's pipelines depend on
    /// it, and those of the passes that leave the map's work out of such a frame (Composite's
    /// lookups, Cull's test of triangles the map shows hidden).
    pub grid_shadows: bool,
    /// The frame's surfaces take the sun's shadow from [`super::ExactShadows`] (tested against the
    /// triangles) instead of the shadow map: only Composite's pipelines depend on it (its map
    /// lookups compile out).
    pub exact_shadows: bool,
    /// Each of Voxelize's items holds all of a ray's words ([`super::Voxelize::words_per_item`]
    /// at least the grid's words per ray: a CPU adapter's list). Cull then takes a point light's
    /// `psi` range from a triangle's bounding ball, which costs it one angle instead of six and no
    /// item (triangle_bounds.wgsl). Only the item passes' pipelines (Cull, Voxelize) depend on it.
    pub whole_ray_items: bool,
    /// The frame keeps its shadow volume as each light ray's first hit
    /// ([`super::ShadowVolume::FirstHits`]): Voxelize's and Integrate's pipelines depend on it.
    pub first_hits: bool,
}

impl Variant {
    /// `sigma_t`: the medium's extinction per channel, as the shaders get it. An epipolar grid with
    /// bins uniform in angle or distance; see [`Variant::with_grid`].
    pub fn new(point_light: bool, phase: &Phase, sigma_t: [f32; 3]) -> Variant {
        let grey = sigma_t[0] == sigma_t[1] && sigma_t[1] == sigma_t[2];
        Variant {
            point_light,
            phase: phase.id(),
            grey,
            cartesian: false,
            cosine_bins: false,
            quad_rays: true,
            grid_shadows: false,
            exact_shadows: false,
            whole_ray_items: false,
            first_hits: false,
        }
    }

    /// The same variant for a grid of the given axes.
    pub fn with_grid(self, cartesian: bool, cosine_bins: bool) -> Variant {
        Variant { cartesian, cosine_bins, ..self }
    }

    /// The same variant for a grid whose rays do (or do not) start on four words.
    pub fn with_quad_rays(self, quad_rays: bool) -> Variant {
        Variant { quad_rays, ..self }
    }

    /// The same variant for a frame whose surface shadows do (or do not) come from the grid.
    pub fn with_grid_shadows(self, grid_shadows: bool) -> Variant {
        Variant { grid_shadows, ..self }
    }

    /// The same variant for a frame whose surfaces do (or do not) take the sun's shadow from
    /// [`super::ExactShadows`].
    pub fn with_exact_shadows(self, exact_shadows: bool) -> Variant {
        Variant { exact_shadows, ..self }
    }

    /// The same variant for a work list whose items do (or do not) hold all of a ray's words.
    pub fn with_whole_ray_items(self, whole_ray_items: bool) -> Variant {
        Variant { whole_ray_items, ..self }
    }

    /// The same variant for a frame whose shadow volume is (or is not) its light rays' first hits.
    pub fn with_first_hits(self, first_hits: bool) -> Variant {
        Variant { first_hits, ..self }
    }

    /// The values of the WGSL `override` constants, as wgpu takes them. Every module imports
    /// `common.wgsl`, which declares them all, so the names always exist.
    pub fn constants(&self) -> [(&'static str, f64); 10] {
        let b = |v: bool| if v { 1.0 } else { 0.0 };
        [
            ("POINT_LIGHT", b(self.point_light)),
            ("PHASE", self.phase as f64),
            ("GREY_MEDIUM", b(self.grey)),
            ("CARTESIAN", b(self.cartesian)),
            ("COSINE_BINS", b(self.cosine_bins)),
            ("QUAD_RAYS", b(self.quad_rays)),
            ("GRID_SHADOWS", b(self.grid_shadows)),
            ("WHOLE_RAY_ITEMS", b(self.whole_ray_items)),
            ("EXACT_SHADOWS", b(self.exact_shadows)),
            ("FIRST_HITS", b(self.first_hits)),
        ]
    }

    /// `, cartesian grid` or `, cosine bins`, empty for an epipolar grid with bins uniform in angle
    /// or distance.
    fn grid_name(&self) -> &'static str {
        match (self.cartesian, self.cosine_bins) {
            (true, _) => ", cartesian grid",
            (false, true) => ", cosine bins",
            (false, false) => "",
        }
    }

    /// The phase function's file name (`henyey-greenstein`).
    pub fn phase_name(&self) -> &'static str {
        Phase::KINDS.get(self.phase as usize).copied().unwrap_or("unknown")
    }
}

impl fmt::Display for Variant {
    /// `point light, henyey-greenstein`
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let light = if self.point_light { "point light" } else { "directional light" };
        let grey = if self.grey { ", grey medium" } else { "" };
        write!(f, "{light}, {}{grey}{}", self.phase_name(), self.grid_name())
    }
}

/// Which of a [`Variant`]'s parts a pass's shader reads: passes that never evaluate the phase
/// function share one pipeline across all of them, and passes that never read the grid's axes one
/// across grids.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Specialised {
    Light,
    LightAndPhase,
    /// The light, the phase and whether the medium is grey (the passes that evaluate
    /// transmittance per sample: the ray march).
    LightPhaseAndMedium,
    /// The light and the grid's axes (Ranges).
    LightAndGrid,
    /// The light and where the surfaces' shadows come from (Composite: the shadow map's lookups
    /// compile out of a grid-shadow frame's pipeline).
    LightAndSurfaceShadows,
    /// The light, the grid's axes, where the surfaces' shadows come from (Cull: its test of
    /// triangles the shadow map shows hidden compiles out of a grid-shadow frame's pipeline) and
    /// whether the work list's items hold whole rays (Cull's `psi` ranges): Cull, Voxelize.
    LightGridAndSurfaceShadows,
    /// Everything but the work list's items: Integrate.
    All,
}

impl Specialised {
    /// Whether the pass builds a pipeline of its own for grid-shadow frames ([`Variant::grid_shadows`]).
    fn reads_surface_shadows(self) -> bool {
        matches!(self, Specialised::LightAndSurfaceShadows | Specialised::LightGridAndSurfaceShadows | Specialised::All)
    }

    /// Whether the pass builds a pipeline of its own for a first-hit volume
    /// ([`Variant::first_hits`]): the passes that write and read it (Voxelize, Integrate), and
    /// Ranges, which takes the planes' reach for it.
    fn reads_volume(self) -> bool {
        matches!(self, Specialised::LightAndGrid | Specialised::LightGridAndSurfaceShadows | Specialised::All)
    }

    /// Whether the pass builds a pipeline of its own for a work list of whole-ray items
    /// ([`Variant::whole_ray_items`]): the passes that make and take the items (Cull, Voxelize).
    fn reads_item_layout(self) -> bool {
        self == Specialised::LightGridAndSurfaceShadows
    }
}

/// A pass's pipelines (or groups of pipelines, `P`), one per variant in use.
pub struct VariantPipelines<P> {
    reads: Specialised,
    built: Vec<(Variant, P)>,
}

impl<P> VariantPipelines<P> {
    pub fn new(reads: Specialised) -> VariantPipelines<P> {
        VariantPipelines { reads, built: Vec::new() }
    }

    /// The variant this pass's pipeline for `v` is built for (the phase dropped when unread).
    pub fn key(&self, v: Variant) -> Variant {
        // Only Integrate (`All`) reads QUAD_RAYS, and only the passes named for them GRID_SHADOWS
        // and WHOLE_RAY_ITEMS: the others share one pipeline across grids, surface shadows and
        // work lists.
        let grid_shadows = v.grid_shadows && self.reads.reads_surface_shadows();
        let exact_shadows = v.exact_shadows && self.reads == Specialised::LightAndSurfaceShadows;
        let whole_ray_items = v.whole_ray_items && self.reads.reads_item_layout();
        // (Cull shares Voxelize's `Specialised`, and with it a pipeline of its own for first hits.)
        let first_hits = v.first_hits && self.reads.reads_volume();
        let v = Variant { whole_ray_items, exact_shadows, first_hits, ..v };
        let v_any_rays = Variant { quad_rays: true, grid_shadows, ..v };
        let epipolar = Variant { cartesian: false, cosine_bins: false, ..v_any_rays };
        match self.reads {
            Specialised::Light | Specialised::LightAndSurfaceShadows => Variant { phase: 0, grey: false, ..epipolar },
            Specialised::LightAndPhase => Variant { grey: false, ..epipolar },
            Specialised::LightPhaseAndMedium => epipolar,
            Specialised::LightAndGrid | Specialised::LightGridAndSurfaceShadows => {
                Variant { phase: 0, grey: false, ..v_any_rays }
            }
            Specialised::All => v,
        }
    }

    /// Builds the pipeline for `v` unless it exists. `build` gets the constants and a label suffix
    /// (`[point light, schlick]`).
    pub fn prepare(&mut self, v: Variant, build: impl FnOnce(&[(&str, f64)], &str) -> P) {
        let key = self.key(v);
        if self.get(v).is_none() {
            let light = if key.point_light { "point light" } else { "directional light" };
            let shadows = match (key.grid_shadows, key.exact_shadows) {
                (true, _) => ", grid shadows",
                (false, true) => ", exact shadows",
                (false, false) => "",
            };
            let items = if key.whole_ray_items { ", whole-ray items" } else { "" };
            let volume = if key.first_hits { ", first hits" } else { "" };
            let label = match self.reads {
                Specialised::Light | Specialised::LightAndSurfaceShadows => format!("[{light}{shadows}]"),
                Specialised::LightAndGrid | Specialised::LightGridAndSurfaceShadows => {
                    format!("[{light}{}{shadows}{items}{volume}]", key.grid_name())
                }
                Specialised::LightAndPhase | Specialised::LightPhaseAndMedium => format!("[{key}]"),
                // Only Integrate tells the grid's ray alignment and the surface shadows apart
                // (implementation details, so not in the variant's name).
                Specialised::All => {
                    format!("[{key}{}{shadows}{volume}]", if key.quad_rays { "" } else { ", rays off four words" })
                }
            };
            let p = build(&key.constants(), &label);
            self.built.push((key, p));
        }
    }

    /// The pipeline for `v`, if [`VariantPipelines::prepare`] built it.
    pub fn get(&self, v: Variant) -> Option<&P> {
        let key = self.key(v);
        self.built.iter().find(|(k, _)| *k == key).map(|(_, p)| p)
    }

    /// The variants built so far.
    pub fn variants(&self) -> impl Iterator<Item = Variant> + '_ {
        self.built.iter().map(|(k, _)| *k)
    }
}

/// A compute pass's specialised pipelines: one pipeline per entry point (`N` of them, sharing one
/// bind-group layout) and per variant in use, labelled `Pass::entry[variant]`.
pub struct SpecialisedCompute<const N: usize> {
    pass: &'static str,
    entries: [&'static str; N],
    module: wgpu::ShaderModule,
    layout: wgpu::PipelineLayout,
    pipelines: VariantPipelines<[wgpu::ComputePipeline; N]>,
}

impl<const N: usize> SpecialisedCompute<N> {
    pub fn new(
        device: &wgpu::Device,
        pass: &'static str,
        module: wgpu::ShaderModule,
        bind_group_layout: &wgpu::BindGroupLayout,
        entries: [&'static str; N],
        reads: Specialised,
    ) -> Self {
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(&format!("{pass}::pipeline_layout")),
            bind_group_layouts: &[Some(bind_group_layout)],
            immediate_size: 0,
        });
        SpecialisedCompute { pass, entries, module, layout, pipelines: VariantPipelines::new(reads) }
    }

    /// Builds the pipelines specialised to `variant` unless they exist.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        let (pass, entries, module, layout) = (self.pass, self.entries, &self.module, &self.layout);
        self.pipelines.prepare(variant, |constants, suffix| {
            entries.map(|entry| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(&format!("{pass}::{entry}{suffix}")),
                    layout: Some(layout),
                    module,
                    entry_point: Some(entry),
                    compilation_options: super::util::options(constants),
                    cache: None,
                })
            })
        });
    }

    /// The pipelines for `variant`, one per entry point, if [`SpecialisedCompute::prepare`] built them.
    pub fn get(&self, variant: Variant) -> Option<&[wgpu::ComputePipeline; N]> {
        self.pipelines.get(variant)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::ShaderLibrary;

    /// Every shader, specialised to every variant the renderer can ask for, still validates: naga
    /// substitutes the constants (as wgpu does when it builds a pipeline) and re-validates the
    /// result. This is what catches an override used in a way only some values allow.
    #[test]
    fn every_shader_specialises_to_every_variant() {
        let lib = ShaderLibrary::embedded();
        let phases = [
            Phase::Isotropic,
            Phase::HenyeyGreenstein { g: 0.5 },
            Phase::Schlick { g: 0.5 },
            Phase::CornetteShanks { g: 0.5 },
            Phase::Rayleigh,
        ];
        let mut specialised = 0;
        for file in crate::gpu::EMBEDDED.iter().map(|(name, _)| *name) {
            if crate::gpu::IMPORTED_ONLY.contains(&file) {
                continue; // declarations only, validated through their users
            }
            let (module, _) = lib.validate(file).unwrap_or_else(|e| panic!("{e}"));
            if module.overrides.is_empty() {
                continue;
            }
            let info =
                naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
                    .validate(&module)
                    .unwrap_or_else(|e| panic!("{file}: {e}"));
            for (point_light, sigma_t) in [(true, [0.1, 0.1, 0.1]), (false, [0.1, 0.1, 0.1]), (false, [0.1, 0.2, 0.3])]
            {
                for (phase, (cartesian, cosine_bins)) in
                    phases.iter().flat_map(|p| [(false, false), (false, true), (true, false)].map(|g| (p, g)))
                {
                    for (quad_rays, grid_shadows, whole_ray_items, exact_shadows) in [
                        (true, false, false, false),
                        (false, false, false, false),
                        (true, true, false, false),
                        (true, false, true, false),
                        (true, false, false, true),
                    ] {
                        let v = Variant::new(point_light, phase, sigma_t)
                            .with_grid(cartesian, cosine_bins)
                            .with_quad_rays(quad_rays)
                            .with_grid_shadows(grid_shadows)
                            .with_whole_ray_items(whole_ray_items)
                            .with_exact_shadows(exact_shadows);
                        let constants: naga::back::PipelineConstants =
                            v.constants().iter().map(|(k, x)| (k.to_string(), *x)).collect();
                        for ep in &module.entry_points {
                            naga::back::pipeline_constants::process_overrides(
                                &module,
                                &info,
                                Some((ep.stage, ep.name.as_str())),
                                &constants,
                            )
                            .unwrap_or_else(|e| panic!("{file}:{} specialised to {v}: {e}", ep.name));
                        }
                    }
                }
            }
            specialised += 1;
        }
        // The passes that depend on the light or the phase (everything but the editor's display).
        assert!(specialised >= 9, "only {specialised} shaders declare the overrides");
    }

    /// The light type and the phase function reach the shaders only as the override constants: no
    /// shader reads them from the per-frame uniforms (where they would be a run-time branch).
    #[test]
    fn no_shader_branches_on_the_light_or_phase_at_run_time() {
        for (file, src) in crate::gpu::EMBEDDED {
            let code: String = src.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n");
            assert!(!code.contains("image.z"), "{file} reads the phase id from the uniforms");
            assert!(!code.contains("FLAG_POINT"), "{file} reads the light type from the uniforms");
            assert!(!code.contains("light.w"), "{file} tells the light type by the light vector's w");
            assert!(!code.contains("params.z"), "{file} tells the light type by the shadow lookup's params.z");
            assert!(!code.contains("FLAG_CARTESIAN"), "{file} reads the grid's kind from the uniforms");
            assert!(!code.contains("FLAG_COSINE_BINS"), "{file} reads the bin spacing from the uniforms");
            assert!(!code.contains("FLAG_GRID_SHADOWS"), "{file} reads the surface shadows' source from the uniforms");
        }
        let common = crate::gpu::EMBEDDED.iter().find(|(f, _)| *f == "common.wgsl").map(|(_, s)| *s).unwrap_or("");
        assert!(common.contains("override POINT_LIGHT") && common.contains("override PHASE"));
        assert!(common.contains("override GREY_MEDIUM"));
        assert!(common.contains("override CARTESIAN") && common.contains("override COSINE_BINS"));
        assert!(common.contains("override QUAD_RAYS") && common.contains("override GRID_SHADOWS"));
        assert!(common.contains("override WHOLE_RAY_ITEMS") && common.contains("override EXACT_SHADOWS"));
    }

    #[test]
    fn light_only_passes_share_a_pipeline_across_phases() {
        let mut p = VariantPipelines::new(Specialised::Light);
        let mut builds = 0;
        for phase in [Phase::Isotropic, Phase::Rayleigh, Phase::HenyeyGreenstein { g: 0.3 }] {
            p.prepare(Variant::new(true, &phase, GREY), |_, _| builds += 1);
        }
        assert_eq!(builds, 1);
        p.prepare(Variant::new(false, &Phase::Rayleigh, COLOURED), |c, label| {
            assert_eq!(c[0], ("POINT_LIGHT", 0.0));
            assert_eq!(label, "[directional light]");
        });
        assert_eq!(p.variants().count(), 2);

        let mut q = VariantPipelines::new(Specialised::LightAndPhase);
        for phase in [Phase::Isotropic, Phase::Rayleigh, Phase::Rayleigh] {
            q.prepare(Variant::new(true, &phase, GREY), |c, _| assert_eq!(c[1].1, phase.id() as f64));
            q.prepare(Variant::new(true, &phase, COLOURED), |_, _| {});
        }
        assert_eq!(q.variants().count(), 2, "passes that do not read the medium share a grey and a coloured one");
        assert!(q.get(Variant::new(true, &Phase::Schlick { g: 0.1 }, GREY)).is_none());

        let mut m = VariantPipelines::new(Specialised::LightPhaseAndMedium);
        m.prepare(Variant::new(false, &Phase::Rayleigh, GREY), |c, label| {
            assert_eq!(c[2], ("GREY_MEDIUM", 1.0));
            assert!(label.contains("grey medium"), "{label}");
        });
        m.prepare(Variant::new(false, &Phase::Rayleigh, COLOURED), |c, _| assert_eq!(c[2], ("GREY_MEDIUM", 0.0)));
        assert_eq!(m.variants().count(), 2);
    }

    /// Only the passes that read the grid's axes build a pipeline per grid; the others (the shadow
    /// map, the surfaces, the ray march) share theirs between a Cartesian, a cosine-binned and a
    /// plain epipolar frame.
    #[test]
    fn only_grid_passes_specialise_to_the_grid() {
        let sun = Variant::new(false, &Phase::Isotropic, GREY);
        let grids = [sun, sun.with_grid(true, false), sun.with_grid(false, true)];
        let mut shared = VariantPipelines::new(Specialised::LightPhaseAndMedium);
        let mut voxels = VariantPipelines::new(Specialised::LightAndGrid);
        let mut integrate = VariantPipelines::new(Specialised::All);
        for v in grids {
            shared.prepare(v, |c, _| {
                assert_eq!(
                    &c[3..],
                    &[
                        ("CARTESIAN", 0.0),
                        ("COSINE_BINS", 0.0),
                        ("QUAD_RAYS", 1.0),
                        ("GRID_SHADOWS", 0.0),
                        ("WHOLE_RAY_ITEMS", 0.0),
                        ("EXACT_SHADOWS", 0.0),
                        ("FIRST_HITS", 0.0)
                    ]
                )
            });
            voxels.prepare(v, |c, _| {
                assert_eq!(c[3], ("CARTESIAN", if v.cartesian { 1.0 } else { 0.0 }));
                assert_eq!(c[4], ("COSINE_BINS", if v.cosine_bins { 1.0 } else { 0.0 }));
            });
            integrate.prepare(v, |_, _| {});
        }
        assert_eq!(shared.variants().count(), 1);
        assert_eq!(voxels.variants().count(), 3);
        assert_eq!(integrate.variants().count(), 3);
        let mut labels = Vec::new();
        voxels.prepare(Variant::new(true, &Phase::Rayleigh, GREY).with_grid(false, true), |_, l| {
            labels.push(l.to_string())
        });
        assert_eq!(labels, ["[point light, cosine bins]"]);
        assert_eq!(sun.with_grid(true, false).to_string(), "directional light, isotropic, grey medium, cartesian grid");
    }

    /// A first-hit frame builds pipelines of its own for the passes that write and read the volume
    /// (Voxelize and Cull, which share a `Specialised`, and Integrate) and for Ranges (the planes'
    /// reach), and shares every other pass's with the bits' frames.
    #[test]
    fn first_hits_specialise_only_the_volumes_passes() {
        let sun = Variant::new(false, &Phase::Isotropic, GREY);
        for (reads, own) in [
            (Specialised::LightGridAndSurfaceShadows, true),
            (Specialised::All, true),
            (Specialised::LightAndGrid, true),
            (Specialised::LightAndSurfaceShadows, false),
            (Specialised::LightPhaseAndMedium, false),
        ] {
            let mut m = VariantPipelines::new(reads);
            m.prepare(sun, |c, _| assert_eq!(c[9], ("FIRST_HITS", 0.0)));
            m.prepare(sun.with_first_hits(true), |c, l| {
                assert_eq!(c[9], ("FIRST_HITS", 1.0));
                assert!(l.contains("first hits"), "{l}");
            });
            assert_eq!(m.variants().count(), if own { 2 } else { 1 }, "{reads:?}");
        }
    }

    /// Whether the grid's rays start on four words changes Integrate's pipeline only; whether the
    /// surfaces' shadows come from the grid changes Integrate's and those of the passes that leave
    /// the map's work out (Composite, Cull), and neither the voxel passes' nor the map's; whether
    /// the work list's items hold whole rays changes only the item passes' (Cull, Voxelize); whether
    /// the sun's shadows on the surfaces are exact only Composite's. None is in the name users see.
    #[test]
    fn the_rays_alignment_grid_shadows_and_items_specialise_only_the_passes_that_read_them() {
        let sun = Variant::new(false, &Phase::Isotropic, GREY);
        let plain = "[directional light, isotropic, grey medium".to_string();
        for (other, i, name, (base, changed), suffix, readers) in [
            (sun.with_quad_rays(false), 5, "QUAD_RAYS", (1.0, 0.0), ", rays off four words", vec![Specialised::All]),
            (
                sun.with_grid_shadows(true),
                6,
                "GRID_SHADOWS",
                (0.0, 1.0),
                ", grid shadows",
                vec![Specialised::All, Specialised::LightAndSurfaceShadows, Specialised::LightGridAndSurfaceShadows],
            ),
            (
                sun.with_whole_ray_items(true),
                7,
                "WHOLE_RAY_ITEMS",
                (0.0, 1.0),
                ", whole-ray items",
                vec![Specialised::LightGridAndSurfaceShadows],
            ),
            (
                sun.with_exact_shadows(true),
                8,
                "EXACT_SHADOWS",
                (0.0, 1.0),
                ", exact shadows",
                vec![Specialised::LightAndSurfaceShadows],
            ),
        ] {
            for reads in [
                Specialised::Light,
                Specialised::LightAndPhase,
                Specialised::LightPhaseAndMedium,
                Specialised::LightAndGrid,
                Specialised::LightAndSurfaceShadows,
                Specialised::LightGridAndSurfaceShadows,
                Specialised::All,
            ] {
                let reader = readers.contains(&reads);
                let mut pipelines = VariantPipelines::new(reads);
                let mut labels = Vec::new();
                for v in [sun, other] {
                    pipelines.prepare(v, |c, label| {
                        assert_eq!(c[i], (name, if v == sun || !reader { base } else { changed }), "{reads:?}");
                        labels.push(label.to_string());
                    });
                }
                assert_eq!(pipelines.variants().count(), if reader { 2 } else { 1 }, "{name}, {reads:?}");
                if reader {
                    assert!(labels[1].ends_with(&format!("{suffix}]")) && !labels[0].contains(suffix), "{labels:?}");
                }
                if reads == Specialised::All && reader {
                    assert_eq!(labels, [format!("{plain}]"), format!("{plain}{suffix}]")]);
                }
            }
            assert_eq!(other.to_string(), sun.to_string(), "{name}: not in the name users see");
        }
        let mut composite = VariantPipelines::new(Specialised::LightAndSurfaceShadows);
        composite
            .prepare(sun.with_grid_shadows(true), |_, label| assert_eq!(label, "[directional light, grid shadows]"));
        let mut cull = VariantPipelines::new(Specialised::LightGridAndSurfaceShadows);
        cull.prepare(sun.with_grid(true, false).with_grid_shadows(true), |_, label| {
            assert_eq!(label, "[directional light, cartesian grid, grid shadows]")
        });
        cull.prepare(sun.with_whole_ray_items(true), |_, label| {
            assert_eq!(label, "[directional light, whole-ray items]")
        });
    }

    const GREY: [f32; 3] = [0.09, 0.09, 0.09];
    const COLOURED: [f32; 3] = [0.09, 0.09, 0.1];
}
