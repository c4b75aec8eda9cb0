mod common;
use epivox::check;
use epivox::render::Method;
#[test]
fn scratch() {
    let Some(mut r) = common::renderer() else { return };
    let mut case = check::matrix(&wgpu::Limits::default()).into_iter().find(|c| c.name == "eye/in-shadow-behind-axis").unwrap();
    for (p, ry) in [(256u32, 256u32), (1024, 1024)] {
        case.scene.grid = epivox::Grid { planes: p, rays: ry, bins: 256, ..Default::default() };
        r.set_scene(&case.scene);
        let out = r.render(&case.scene, 48, 48, Method::Vsv).unwrap();
        let g = r.read_grid().unwrap();
        let words = 8usize;
        let m = out.setup.mapping;
        let bin14 = m.bin_coord((0.5f64/2.0).atan()) as usize;
        eprintln!("grid {p}x{ry}: z range {:.4}..{:.4}, gamma {:.4}..{:.4}, bin of 14deg {bin14}", m.z_lo, m.z_hi, m.gamma_lo, m.gamma_hi);
        for row in [0usize, 1, (ry/2) as usize, (ry-1) as usize] {
            let mut missing = 0; let mut first = vec![];
            for x in 0..p as usize {
                let base = (row * p as usize + x) * words;
                // bins 0..bin14-2 should be set
                let ok = (0..bin14.saturating_sub(2)).all(|b| g[base + b/32] >> (b%32) & 1 == 1);
                if !ok { missing += 1; if first.len() < 8 { first.push(x); } }
            }
            eprintln!("  row {row}: {missing} of {p} planes miss shade bits, e.g. {first:?}");
        }
    }
}
