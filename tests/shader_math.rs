//! common.wgsl's numerics, run on the adapter (the software Vulkan driver in CI) and compared with
//! f64 on the CPU.

mod common;

use common::renderer;
use epivox::gpu::ShaderLibrary;
use wgpu::util::DeviceExt;

/// Evaluates `function` of common.wgsl (f32 -> f32) at each of `xs` on the GPU.
fn eval(function: &str, xs: &[f32]) -> Option<Vec<f32>> {
    let pairs: Vec<[f32; 2]> = xs.iter().map(|&x| [x, 0.0]).collect();
    eval_expr(&format!("{function}(p.x)"), &pairs)
}

/// Evaluates the WGSL expression `expr` of `p` (a vec2f, with common.wgsl imported) at each of
/// `ps` on the GPU.
fn eval_expr(expr: &str, ps: &[[f32; 2]]) -> Option<Vec<f32>> {
    // (The shared helper: it skips with the usual message when there is no adapter at all.)
    let r = renderer()?;
    let ctx = &r.ctx;
    // A probe shader beside the embedded ones: a folder holding only it (imports fall back to
    // the embedded common.wgsl).
    let tag: String = expr.chars().filter(|c| c.is_ascii_alphanumeric()).take(40).collect();
    let dir = std::env::temp_dir().join(format!("epivox-shader-math-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let probe = format!(
        "#import common\n\
         @group(0) @binding(0) var<storage, read_write> xs: array<vec2f>;\n\
         @compute @workgroup_size(64)\n\
         fn main(@builtin(global_invocation_id) id: vec3u) {{\n\
             if (id.x < arrayLength(&xs)) {{ let p = xs[id.x]; xs[id.x] = vec2f({expr}, 0.0); }}\n\
         }}\n"
    );
    std::fs::write(dir.join("probe.wgsl"), probe).unwrap_or_else(|e| panic!("{e}"));
    let library = ShaderLibrary::new(Some(dir.clone()));
    let module = library.module(&ctx.device, "probe.wgsl").unwrap_or_else(|e| panic!("{e}"));
    let _ = std::fs::remove_dir_all(&dir);
    let device = &ctx.device;
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("shader_math::pipeline"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bytes: Vec<u8> = ps.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("shader_math::xs"),
        contents: &bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("shader_math::bind_group"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
    });
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("shader_math") });
    {
        let mut pass =
            enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("shader_math"), timestamp_writes: None });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((ps.len() as u32).div_ceil(64), 1, 1);
    }
    ctx.queue.submit([enc.finish()]);
    let out = ctx.read_buffer(&buffer).unwrap_or_else(|e| panic!("{e}"));
    Some(out.chunks_exact(8).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
}

/// sin_rel keeps a small relative error at both ends of [0, pi], where Integrate divides by it
/// (1 / sin(gamma) for the ray through a point light). WGSL lets sin itself err by 2^-11 in
/// absolute terms; the series must hold 1e-6 relative (a few f32 ulps) from 1e-30 up to 0.25 rad
/// from 0, whatever the driver's sin. Toward pi the distance pi - x is taken from f32(pi), 8.7e-8
/// above pi, so there the bound is 1e-6 relative plus 1e-7 absolute. The middle is the driver's
/// sin: 1e-4 relative is what llvmpipe and hardware easily give (2^-11 would allow 5e-4 at 1 rad).
#[test]
fn sin_rel_is_relatively_accurate_near_zero_and_pi() {
    let pi = std::f64::consts::PI;
    let mut xs: Vec<f32> = (0..=300).map(|i| 10f64.powf(-30.0 + 29.4 * i as f64 / 300.0) as f32).collect();
    // Toward pi: pi minus the same small distances, as f32 (the nearest f32 below pi and up).
    let near_pi: Vec<f32> = xs.iter().map(|&d| (pi - d as f64) as f32).filter(|&x| (x as f64) < pi).collect();
    xs.extend(near_pi);
    xs.extend((1..100).map(|i| (pi * i as f64 / 100.0) as f32));
    // Up to the series' end, where its truncation is largest.
    xs.extend((0..50).map(|i| (0.2 + 0.05 * i as f64 / 50.0) as f32));
    let Some(got) = eval("sin_rel", &xs) else { return };
    let mut checked_ends = 0;
    for (&x, &g) in xs.iter().zip(&got) {
        let exact = (x as f64).sin();
        let err = (g as f64 - exact).abs();
        let end = (x as f64).min(pi - x as f64) < 0.25;
        let bound = match (end, (x as f64) > 0.5 * pi) {
            (true, false) => 1e-6 * exact,
            (true, true) => 1e-6 * exact + 1e-7,
            (false, _) => 1e-4 * exact,
        };
        assert!(err <= bound, "sin_rel({x:e}) = {g:e}, sin = {exact:e}: error {err:e} (bound {bound:e})");
        checked_ends += end as usize;
    }
    assert!(checked_ends > 300, "{checked_ends} points near the ends");
}

/// atan2_approx (common.wgsl) stands for atan2 where an angle only bins or bounds: Voxelize's hit
/// cells, and Cull's ranges, whose margin for it (`ANGLE_MARGIN` in triangle_bounds.wgsl) is
/// 4e-6 rad. Its polynomial errs by 1.7e-6 rad at most (f64); on the adapter, over every octant
/// (4096 directions around the circle, and each octant edge with points 1e-7 and 1e-6 rad either
/// side of it) and at lengths from 1e-36 to 1e30, it must stay within 2.5e-6 rad of the f64 atan2
/// of the same f32 point, which leaves the margin room for f32's rounding. At (0, 0) it is 0, as
/// atan2 is.
#[test]
fn atan2_approx_stays_within_its_bound_in_every_octant() {
    let (pi, tau) = (std::f64::consts::PI, std::f64::consts::TAU);
    let mut angles: Vec<f64> = (0..4096).map(|i| -pi + tau * (i as f64 + 0.5) / 4096.0).collect();
    for k in -4..=4 {
        let edge = std::f64::consts::FRAC_PI_4 * k as f64;
        angles.extend([-1e-6, -1e-7, 0.0, 1e-7, 1e-6].iter().map(|d| edge + d));
    }
    for scale in [1e-36f64, 1e-3, 1.0, 1e3, 1e30] {
        let points: Vec<[f32; 2]> =
            angles.iter().map(|a| [(a.sin() * scale) as f32, (a.cos() * scale) as f32]).collect();
        let Some(got) = eval_expr("atan2_approx(p.x, p.y)", &points) else { return };
        let (mut worst, mut at) = (0.0f64, 0usize);
        for (i, (&[y, x], &g)) in points.iter().zip(&got).enumerate() {
            let want = (y as f64).atan2(x as f64);
            // Either side of the cut at pi is the same direction.
            let d = (g as f64 - want).abs();
            let err = d.min((d - tau).abs());
            if err > worst {
                (worst, at) = (err, i);
            }
        }
        let [y, x] = points[at];
        assert!(worst <= 2.5e-6, "scale {scale:e}: atan2_approx({y:e}, {x:e}) is {worst:e} rad off (bound 2.5e-6)");
    }
    let Some(origin) = eval_expr("atan2_approx(p.x, p.y)", &[[0.0, 0.0]]) else { return };
    assert_eq!(origin[0], 0.0, "atan2_approx(0, 0)");
}

/// Voxelize's first hits take their angles from atan2_approx (voxelize.wgsl, `first_hits`), and
/// Integrate compares them with the pixel's own angle moved on by half a plane's angle times
/// sin(gamma) (integrate.wgsl `HIT_SLACK`): 2.4e-4 sin(gamma) at 2048 planes over one radian (the
/// classroom's span is 0.83). Where the approximation errs by more than that, a lit surface would
/// shadow itself. Its error must stay within a sixth of it, 4e-5 sin(gamma) (plus f32's rounding of
/// the angle itself), over the half-plane the light rays' hits lie in (v >= 0), from 1e-6 rad of
/// the axis to 1e-6 rad of its far side, where the polynomial's absolute bound alone (1.7e-6 rad)
/// would not do: there its error is 2.3e-5 of the angle's distance from the axis.
#[test]
fn atan2_approx_errs_within_the_first_hits_slack() {
    let pi = std::f64::consts::PI;
    let mut angles: Vec<f64> = (0..2048).map(|i| pi * (i as f64 + 0.5) / 2048.0).collect();
    for e in 0..=50 {
        let a = 10f64.powf(-6.0 + 5.0 * e as f64 / 50.0);
        angles.extend([a, pi - a]);
    }
    for scale in [1e-3f64, 1.0, 1e3] {
        let points: Vec<[f32; 2]> =
            angles.iter().map(|a| [(a.sin() * scale) as f32, (a.cos() * scale) as f32]).collect();
        let Some(got) = eval_expr("atan2_approx(p.x, p.y)", &points) else { return };
        for (&[y, x], &g) in points.iter().zip(&got) {
            let want = (y as f64).atan2(x as f64);
            let ulp = f64::from(f32::EPSILON) * want;
            let bound = 4e-5 * want.sin() + ulp;
            let err = (g as f64 - want).abs();
            assert!(err <= bound, "atan2_approx({y:e}, {x:e}) is {err:e} rad off {want} (bound {bound:e})");
        }
    }
}
