//! The tables an extraction fills: one row per CCD frame, per (thermal frame, ROI), per joint
//! state and per ambient reading, as columns.

use crate::centroid::SpotStatus;

/// Frame statuses in the order of their codes in [`FrameTable::status`].
pub const STATUS_NAMES: [&str; 7] = [
    "ok",
    "no_spot",
    "saturated",
    "at_border",
    "multiple",
    "streak",
    "invalid",
];
pub(super) const STATUS_INVALID: u8 = 6;

pub(super) fn status_code(s: SpotStatus) -> u8 {
    match s {
        SpotStatus::Ok => 0,
        SpotStatus::NoSpot => 1,
        SpotStatus::Saturated => 2,
        SpotStatus::AtBorder => 3,
        SpotStatus::Multiple => 4,
        SpotStatus::Streak => 5,
    }
}

/// One row per CCD frame.
#[derive(Debug, Default, Clone)]
pub struct FrameTable {
    /// Index of the camera in the rig.
    pub camera: Vec<u32>,
    /// Header stamp (ns), or the log time where the stamp is zero.
    pub t_ns: Vec<i64>,
    pub x_px: Vec<f64>,
    pub y_px: Vec<f64>,
    pub peak: Vec<f64>,
    pub signal: Vec<f64>,
    pub size_px: Vec<f64>,
    pub background: Vec<f64>,
    pub noise: Vec<f64>,
    /// Index into [`STATUS_NAMES`].
    pub status: Vec<u8>,
}

/// One row per (thermal frame, ROI).
#[derive(Debug, Default, Clone)]
pub struct ThermalTable {
    pub t_ns: Vec<i64>,
    /// Index of the ROI in the rig.
    pub roi: Vec<u32>,
    pub max_c: Vec<f64>,
    pub peak_c: Vec<f64>,
    pub x_px: Vec<u32>,
    pub y_px: Vec<u32>,
}

/// One row per joint-state message, positions in the rig's joint order (radians).
#[derive(Debug, Default, Clone)]
pub struct JointTable {
    pub t_ns: Vec<i64>,
    /// N × 6, row-major.
    pub position: Vec<f64>,
}

/// One row per ambient reading.
#[derive(Debug, Default, Clone)]
pub struct AmbientTable {
    pub t_ns: Vec<i64>,
    pub temperature_c: Vec<f64>,
}

/// All tables of one recording.
#[derive(Debug, Default, Clone)]
pub struct Tables {
    pub frames: FrameTable,
    pub thermal: ThermalTable,
    pub joints: JointTable,
    pub ambient: AmbientTable,
}

macro_rules! append_all {
    ($dst:expr, $src:expr, $($f:ident),*) => { $( $dst.$f.extend_from_slice(&$src.$f); )* };
}

impl Tables {
    pub(super) fn append(&mut self, o: &Tables) {
        append_all!(
            self.frames,
            o.frames,
            camera,
            t_ns,
            x_px,
            y_px,
            peak,
            signal,
            size_px,
            background,
            noise,
            status
        );
        append_all!(
            self.thermal,
            o.thermal,
            t_ns,
            roi,
            max_c,
            peak_c,
            x_px,
            y_px
        );
        append_all!(self.joints, o.joints, t_ns, position);
        append_all!(self.ambient, o.ambient, t_ns, temperature_c);
    }
}

pub(super) fn invalid_frame(f: &mut FrameTable, cam: usize, t: i64) {
    f.camera.push(cam as u32);
    f.t_ns.push(t);
    for col in [
        &mut f.x_px,
        &mut f.y_px,
        &mut f.peak,
        &mut f.signal,
        &mut f.size_px,
        &mut f.background,
        &mut f.noise,
    ] {
        col.push(f64::NAN);
    }
    f.status.push(STATUS_INVALID);
}
