//! What the templates of the probing tests share: how touches are made
//! (`probing:` clearance, overtravel, feeds, margins, overheads) and the
//! probe's stylus and body (`probe:`), read and checked (every error names
//! the key, `file:line:column`). Each test reads the rest of its template
//! in its own folder.

use serde::Deserialize;

use super::ProbingSettings;
use crate::limits::MAX_PLAN_OVERHEAD_S;
use crate::procedure::TemplateSource;
use crate::procedure::bounds::{echo, feed, length, within};
use crate::source::SourceError;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ProbingFile {
    clearance: f64,
    overtravel: f64,
    feed: f64,
    positioning_feed: f64,
    safe_margin: f64,
    touch_overhead: f64,
    pose_overhead: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ProbeFile {
    stylus_length: f64,
    stylus_diameter: f64,
    body_diameter: f64,
    #[serde(default)]
    body_length: Option<f64>,
    spindle_diameter: f64,
    spindle_length: f64,
}

/// Stylus and body of the probe (the ball comes from the machine file).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StylusSpec {
    /// Ball centre to the probe body, mm.
    pub stylus_length: f64,
    /// Shaft diameter, mm.
    pub stylus_diameter: f64,
    /// Body diameter, mm.
    pub body_diameter: f64,
    /// Body length, mm; `None`: up to the spindle gauge line.
    pub body_length: Option<f64>,
    /// Diameter of the spindle nose, mm.
    pub spindle_diameter: f64,
    /// Length of the spindle nose modelled above the gauge line, mm.
    pub spindle_length: f64,
}

pub(crate) fn settings(
    src: &TemplateSource,
    p: &ProbingFile,
) -> Result<ProbingSettings, SourceError> {
    let k = |key: &'static str| ["probing", key];
    length(src, &k("clearance"), p.clearance)?;
    length(src, &k("overtravel"), p.overtravel)?;
    feed(src, &k("feed"), p.feed)?;
    feed(src, &k("positioning_feed"), p.positioning_feed)?;
    if !(p.safe_margin.is_finite() && p.safe_margin >= 0.0 && p.safe_margin < p.clearance) {
        return Err(src.error(
            &k("safe_margin"),
            format!(
                "probing.safe_margin must be at least 0 and smaller than the clearance ({} mm), got {}",
                p.clearance,
                echo(p.safe_margin)
            ),
        ));
    }
    for (key, v) in [
        ("touch_overhead", p.touch_overhead),
        ("pose_overhead", p.pose_overhead),
    ] {
        within(src, &k(key), v, (0.0, MAX_PLAN_OVERHEAD_S), "s", "")?;
    }
    Ok(ProbingSettings {
        clearance: p.clearance,
        overtravel: p.overtravel,
        feed: p.feed,
        positioning_feed: p.positioning_feed,
        safe_margin: p.safe_margin,
        touch_overhead: p.touch_overhead,
        pose_overhead: p.pose_overhead,
    })
}

pub(crate) fn stylus(src: &TemplateSource, p: &ProbeFile) -> Result<StylusSpec, SourceError> {
    let k = |key: &'static str| ["probe", key];
    length(src, &k("stylus_length"), p.stylus_length)?;
    length(src, &k("stylus_diameter"), p.stylus_diameter)?;
    length(src, &k("body_diameter"), p.body_diameter)?;
    if let Some(l) = p.body_length {
        length(src, &k("body_length"), l)?;
    }
    length(src, &k("spindle_diameter"), p.spindle_diameter)?;
    length(src, &k("spindle_length"), p.spindle_length)?;
    Ok(StylusSpec {
        stylus_length: p.stylus_length,
        stylus_diameter: p.stylus_diameter,
        body_diameter: p.body_diameter,
        body_length: p.body_length,
        spindle_diameter: p.spindle_diameter,
        spindle_length: p.spindle_length,
    })
}
