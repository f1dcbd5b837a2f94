//! What a simulation needs before the first cycle: the scenario's effects and forward model,
//! the thermal nodes (the scenario's or the KR 15/2 calibration), which node or ambient feeds
//! each temperature the model needs, and the recording writer with one channel per topic.

use std::io::{Seek, Write};

use crate::effects::Effects;
use crate::error::{Error, FileKind, NameKind, Result, RigError, UnknownName};
use crate::heat::{self, NodeParams};
use crate::model::ForwardModel;
use crate::record::{MsgType, RecordCompression, RecordError, RecordOptions, RecordingWriter};
use crate::rig::{Rig, Thermal, AMBIENT};
use crate::scenario::Scenario;

/// A failed write of the recording (the bindings name the file).
pub(super) fn write_error(source: RecordError) -> Error {
    Error::Write {
        target: "the recording".into(),
        source,
    }
}

/// The fixed parts of a simulation.
pub(super) struct Setup<'a> {
    pub(super) rig: &'a Rig,
    pub(super) sc: &'a Scenario,
    pub(super) th: &'a Thermal,
    pub(super) fx: Effects,
    pub(super) model: ForwardModel,
    pub(super) nodes: Vec<NodeParams>,
    /// Per node, its ROI's index in the thermal camera.
    pub(super) node_roi: Vec<usize>,
    /// For every temperature the model needs: which node, or ambient (`None`).
    pub(super) temp_src: Vec<Option<usize>>,
    /// When the first run starts (ns since the Unix epoch): the scenario's `start_time`.
    pub(super) t0_ns: i64,
    /// Per run, the idle (cooling) time before it (s): `idle_before_min` or up to its
    /// `start_time`.
    pub(super) idle_s: Vec<f64>,
    /// The CCD frames' background distribution ([`super::render::ccd_background`]).
    pub(super) ccd_background: super::render::RoundedNormal,
}

impl<'a> Setup<'a> {
    /// Check the rig and scenario fit together and build what the cycles use.
    pub(super) fn new(rig: &'a Rig, sc: &'a Scenario) -> Result<Setup<'a>> {
        let th = rig.thermal.as_ref().ok_or(Error::NoThermalCamera)?;
        let fx = effects(rig, sc)?;
        let model = ForwardModel::new(rig, &fx.params)?;
        let nodes = nodes(rig, sc)?;
        let roi_names: Vec<String> = th.roi.iter().map(|r| r.name.clone()).collect();
        let node_roi: Vec<usize> = nodes
            .iter()
            .map(|n| {
                roi_names
                    .iter()
                    .position(|r| *r == n.name)
                    .expect("checked")
            })
            .collect();
        let temp_src = temperature_sources(&model, &nodes)?;
        let idle_s = sc.idle_before_s().map_err(|e| RigError {
            kind: FileKind::Scenario,
            source_name: "the scenario".into(),
            line: None,
            key: e.key,
            message: e.message,
        })?;
        Ok(Setup {
            rig,
            sc,
            th,
            fx,
            model,
            nodes,
            node_roi,
            temp_src,
            t0_ns: sc.start_time.unwrap_or(super::T0_NS),
            idle_s,
            ccd_background: super::render::ccd_background(
                &sc.camera,
                if sc.camera.bits == 8 { 1 } else { 2 },
            ),
        })
    }

    /// The writer of the recording, with a channel per topic the rig records.
    pub(super) fn writer<W: Write + Seek>(&self, out: W) -> Result<RecordingWriter<W>> {
        let (rig, sc) = (self.rig, self.sc);
        let opts = RecordOptions {
            compression: sc
                .output
                .compression
                .parse::<RecordCompression>()
                .map_err(|_| {
                    UnknownName::new(
                        "output",
                        NameKind::Compression,
                        &sc.output.compression,
                        RecordCompression::ALL
                            .iter()
                            .map(|c| c.to_string())
                            .collect(),
                    )
                })?,
            chunk_size: sc.output.chunk_size,
            ..RecordOptions::default()
        };
        let mut wr = RecordingWriter::new(out, &opts).map_err(write_error)?;
        wr.add_channel(&rig.robot.joint_states_topic, MsgType::JointState)
            .map_err(write_error)?;
        for c in &rig.camera {
            wr.add_channel(&c.topic, MsgType::Image)
                .map_err(write_error)?;
        }
        wr.add_channel(&self.th.topic, MsgType::Image)
            .map_err(write_error)?;
        if let Some(a) = &rig.ambient {
            wr.add_channel(&a.topic, MsgType::Temperature)
                .map_err(write_error)?;
        }
        Ok(wr)
    }

    /// The model's temperatures from the nodes' (structure) temperatures and ambient.
    pub(super) fn model_temperatures(&self, structure: &[f64], ambient: f64) -> Vec<f64> {
        self.temp_src
            .iter()
            .map(|s| s.map(|k| structure[k]).unwrap_or(ambient))
            .collect()
    }
}

/// A scenario's effects on a rig (see [`crate::effects`]).
fn effects(rig: &Rig, sc: &Scenario) -> Result<Effects> {
    let list = sc.effects()?;
    Effects::build(
        rig,
        &list,
        rig.expansion.alpha_per_k,
        rig.expansion.reference_c,
    )
}

/// Thermal nodes: the scenario's, else the KR 15/2 calibration; each must be a ROI of the rig.
fn nodes(rig: &Rig, sc: &Scenario) -> Result<Vec<NodeParams>> {
    let nodes: Vec<NodeParams> = if sc.node.is_empty() {
        // The calibration's nodes of the ROIs this rig has (a rig with link 2 and link 3
        // but no base ROI is simulated with those two).
        let rois = rig.rois();
        heat::kr15_paper_nodes()
            .into_iter()
            .filter(|n| rois.contains_key(&n.name))
            .collect()
    } else {
        sc.node
            .iter()
            .map(|n| {
                let rise = n.rise().ok_or_else(|| Error::NodeRise {
                    node: n.name.clone(),
                })?;
                Ok(NodeParams::new(n.name.clone(), n.tau_min, rise)?)
            })
            .collect::<Result<_>>()?
    };
    let rois = rig.rois();
    for n in &nodes {
        if !rois.contains_key(&n.name) {
            let known = rois.keys().cloned().collect();
            return Err(UnknownName::new("", NameKind::ThermalNode, &n.name, known).into());
        }
    }
    Ok(nodes)
}

/// For every temperature the model needs: which node, or ambient (`None`).
fn temperature_sources(model: &ForwardModel, nodes: &[NodeParams]) -> Result<Vec<Option<usize>>> {
    model
        .temperature_names()
        .iter()
        .map(|t| {
            if t == AMBIENT {
                Ok(None)
            } else {
                nodes
                    .iter()
                    .position(|n| n.name == *t)
                    .map(Some)
                    .ok_or_else(|| {
                        let known = nodes.iter().map(|n| n.name.clone()).collect();
                        UnknownName::new("", NameKind::SimulatedTemperature, t, known).into()
                    })
            }
        })
        .collect()
}
