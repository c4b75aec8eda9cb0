//! The panels. Each is a small struct that draws itself from the editor's state and pushes
//! [`Command`]s; none changes editor state (only [`super::Editor::apply`] does). All share one
//! signature, [`Panel::show`], with the state to read in a [`PanelCtx`] (as egui's demo `View`).
//!
//! Every slider takes its range, unit and tooltip from the parameter's [`Spec`] in `params.rs`.

mod accuracy;
mod grid;
pub mod inspector;
mod light;
mod medium;
pub mod menu;
mod phase;
mod presets;
mod stats;
pub mod toolbar;
pub mod viewport;

pub use accuracy::AccuracyPanel;
pub use grid::{GridLimits, GridPanel};
pub use light::LightPanel;
pub use medium::MediumPanel;
pub use phase::PhasePanel;
pub use presets::PresetsPanel;
pub use stats::StatsPanel;

use super::document::Document;
use super::jobs::Jobs;
use super::session::Session;
use super::view::View;

/// What a panel may read: the whole editor state, borrowed for one frame.
pub struct PanelCtx<'a> {
    pub doc: &'a Document,
    pub view: &'a View,
    pub jobs: &'a Jobs,
    pub session: &'a Session,
    /// Smoothed time between UI frames (ms).
    pub ui_frame_ms: f64,
}

/// A panel: draws from the state and asks for changes.
pub trait Panel {
    /// The header it is shown under.
    fn name(&self) -> &'static str;
    /// Draws the panel and pushes what the user asked for to `out`.
    fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, out: &mut Vec<Command>);
}

use super::command::{merge_key, Command, MergeKey};
use crate::params::Spec;
use eframe::egui;

/// A slider over `spec`'s range (logarithmic when it spans decades), labelled with `label` and
/// the unit, with the spec's sentence as tooltip. Returns the response and its merge key.
pub fn spec_slider(ui: &mut egui::Ui, value: &mut f32, spec: &Spec, label: &str) -> (egui::Response, MergeKey) {
    // Decades of range (coefficients, densities, intensities) need a logarithmic scale.
    let log = spec.min >= 0.0 && spec.max / spec.min.max(1.0) >= 100.0;
    let mut s = egui::Slider::new(value, spec.min as f32..=spec.max as f32).text(label).logarithmic(log);
    if log {
        // How close to zero the logarithmic scale reaches before it snaps to 0.
        s = s.smallest_positive((spec.max * 1e-9).max(1e-6));
    }
    if !spec.unit.is_empty() {
        s = s.suffix(format!(" {}", spec.unit));
    }
    let r = ui.add(s).on_hover_text(spec.doc);
    let k = merge_key(&r);
    (r, k)
}

/// Three sliders (R, G, B) over `spec`, or one when `linked` (all channels equal). Returns the
/// new value when one changed.
pub fn rgb_sliders(
    ui: &mut egui::Ui,
    value: glam::Vec3,
    spec: &Spec,
    label: &str,
    linked: bool,
) -> Option<(glam::Vec3, MergeKey)> {
    let mut out = None;
    ui.push_id(label, |ui| {
        if linked {
            let mut v = value.max_element();
            let (r, k) = spec_slider(ui, &mut v, spec, label);
            if r.changed() {
                out = Some((glam::Vec3::splat(v), k));
            }
        } else {
            let mut v = value.to_array();
            for (i, ch) in ["R", "G", "B"].iter().enumerate() {
                let (r, k) = spec_slider(ui, &mut v[i], spec, &format!("{label} {ch}"));
                if r.changed() {
                    out = Some((glam::Vec3::from_array(v), k));
                }
            }
        }
    });
    out
}

/// Bytes as KiB/MiB/GiB.
pub fn bytes(n: u64) -> String {
    let n = n as f64;
    if n >= 1024.0 * 1024.0 * 1024.0 {
        format!("{:.2} GiB", n / (1024.0 * 1024.0 * 1024.0))
    } else if n >= 1024.0 * 1024.0 {
        format!("{:.1} MiB", n / (1024.0 * 1024.0))
    } else {
        format!("{:.1} KiB", n / 1024.0)
    }
}
