//! Interpreting a message: dispatched by its topic's role to the frame, thermal, joint-state
//! or ambient reader (units of work, chunks and loose batches, are run in `work.rs`).

use mcap::records::MessageHeader;

use super::*;

impl<'r> Context<'r> {
    /// Interpret one message into `part`. Returns false if its channel, or its channel's
    /// schema, is not known (yet).
    pub(super) fn message(
        &self,
        reg: &Registry,
        local: &Registry,
        h: &MessageHeader,
        data: &[u8],
        part: &mut Part,
    ) -> bool {
        let Some(ch) = local
            .channels
            .get(&h.channel_id)
            .or_else(|| reg.channels.get(&h.channel_id))
        else {
            return false;
        };
        // rosbag2's message compression: each message a zstd frame of its CDR bytes (a CDR
        // message starts with its encapsulation, 0x00 0x0N, never with the zstd magic).
        if data.starts_with(ZSTD_MAGIC) && self.roles.contains_key(ch.topic.as_str()) {
            return match zstd::bulk::decompress(data, MAX_CHUNK_BYTES as usize) {
                Ok(plain) => self.message(reg, local, h, &plain, part),
                Err(e) => {
                    part.report.skip(
                        &ch.topic,
                        format!("the zstd-compressed message does not decompress: {e}"),
                    );
                    true
                }
            };
        }
        let Some(&role) = self.roles.get(ch.topic.as_str()) else {
            part.report.other_messages += 1;
            return true;
        };
        // A schema defined elsewhere (a chunk run beside this one): read again once it is known.
        let Some(schema) = local
            .schemas
            .get(&ch.schema_id)
            .or_else(|| reg.schemas.get(&ch.schema_id))
            .map(String::as_str)
            .or((ch.schema_id == 0).then_some(""))
        else {
            return false;
        };
        let topic = ch.topic.as_str();
        // Counted without a new `String` per message: the key is made once per topic.
        match part.report.messages.get_mut(topic) {
            Some(n) => *n += 1,
            None => {
                part.report.messages.insert(topic.to_string(), 1);
            }
        }
        let ros1 = ch.encoding == "ros1";
        if !ros1 && ch.encoding != "cdr" {
            part.report.skip(
                topic,
                format!("message encoding {:?} is not cdr", ch.encoding),
            );
            if let Role::Camera(i) = role {
                invalid_frame(&mut part.tables.frames, i, h.log_time as i64);
            }
            return true;
        }
        let stamp = |ns: i64| if ns == 0 { h.log_time as i64 } else { ns };
        match role {
            Role::Camera(i) => self.camera_frame(i, topic, schema, ros1, data, h, part),
            Role::Thermal => self.thermal_frame(topic, schema, ros1, data, h, part),
            Role::Joints => match (schema, joint_state(ros1, data)) {
                (JOINT_STATE, Ok(js)) => {
                    let mut row = [f64::NAN; 6];
                    for (k, name) in self.rig.robot.joint_names.iter().enumerate() {
                        match js.names.iter().position(|n| n == name) {
                            Some(j) if j < js.position.len() => row[k] = js.position[j],
                            _ => {
                                part.report.skip(topic, format!("joint {name:?} missing"));
                                return true;
                            }
                        }
                    }
                    part.tables.joints.t_ns.push(stamp(js.stamp_ns));
                    part.tables.joints.position.extend_from_slice(&row);
                }
                (JOINT_STATE, Err(e)) => part.report.skip(topic, format!("bad JointState: {e}")),
                (s, _) => part
                    .report
                    .skip(topic, format!("schema {s:?} is not {JOINT_STATE}")),
            },
            Role::Ambient => match (schema, temperature(ros1, data)) {
                (TEMPERATURE, Ok(t)) => {
                    part.tables.ambient.t_ns.push(stamp(t.stamp_ns));
                    part.tables.ambient.temperature_c.push(t.temperature);
                }
                (TEMPERATURE, Err(e)) => part.report.skip(topic, format!("bad Temperature: {e}")),
                (s, _) => part
                    .report
                    .skip(topic, format!("schema {s:?} is not {TEMPERATURE}")),
            },
        }
        true
    }

    #[allow(clippy::too_many_arguments)]
    fn camera_frame(
        &self,
        cam: usize,
        topic: &str,
        schema: &str,
        ros1: bool,
        data: &[u8],
        h: &MessageHeader,
        part: &mut Part,
    ) {
        let c = &self.rig.camera[cam];
        let (w, hgt) = (c.size_px[0] as usize, c.size_px[1] as usize);
        let log_t = h.log_time as i64;
        let res: std::result::Result<(i64, centroid::Spot), String> = match schema {
            IMAGE => image(ros1, data)
                .map_err(|e| format!("bad Image: {e}"))
                .and_then(|im| {
                    let t = if im.stamp_ns == 0 { log_t } else { im.stamp_ns };
                    let bpp = match im.encoding {
                        "mono8" | "8UC1" => 1,
                        "mono16" | "16UC1" => 2,
                        e => return Err(format!("encoding {e:?} is not mono8/8UC1/mono16/16UC1")),
                    };
                    if (im.width as usize, im.height as usize) != (w, hgt) {
                        return Err(format!(
                            "frame is {}x{}, the rig says {w}x{hgt}",
                            im.width, im.height
                        ));
                    }
                    let view =
                        FrameView::new(im.data, w, hgt, im.step as usize, bpp, im.is_bigendian)?;
                    Ok((t, centroid::find_spot(&view, &self.spot)))
                }),
            COMPRESSED => compressed_image(ros1, data)
                .map_err(|e| format!("bad CompressedImage: {e}"))
                .and_then(|im| {
                    let t = if im.stamp_ns == 0 { log_t } else { im.stamp_ns };
                    let (pixels, bpp) = decode_png(im.format, im.data, (w, hgt))?;
                    let view =
                        FrameView::new(&pixels, w, hgt, w * bpp, bpp, cfg!(target_endian = "big"))?;
                    Ok((t, centroid::find_spot(&view, &self.spot)))
                }),
            s => Err(format!("schema {s:?} is not an image")),
        };
        let f = &mut part.tables.frames;
        match res {
            Ok((t, s)) => {
                f.camera.push(cam as u32);
                f.t_ns.push(t);
                f.x_px.push(s.x_px);
                f.y_px.push(s.y_px);
                f.peak.push(s.peak);
                f.signal.push(s.signal);
                f.size_px.push(s.size_px);
                f.background.push(s.background);
                f.noise.push(s.noise);
                f.status.push(status_code(s.status));
            }
            Err(reason) => {
                part.report.skip(topic, reason);
                invalid_frame(f, cam, log_t);
            }
        }
    }

    fn thermal_frame(
        &self,
        topic: &str,
        schema: &str,
        ros1: bool,
        data: &[u8],
        h: &MessageHeader,
        part: &mut Part,
    ) {
        let Some(th) = &self.rig.thermal else { return };
        let (w, hgt) = (th.size_px[0] as usize, th.size_px[1] as usize);
        let log_t = h.log_time as i64;
        let res: std::result::Result<(i64, Vec<crate::thermal::RoiMax>), String> = match schema {
            IMAGE => image(ros1, data)
                .map_err(|e| format!("bad Image: {e}"))
                .and_then(|im| {
                    let t = if im.stamp_ns == 0 { log_t } else { im.stamp_ns };
                    let fmt = ThermalFormat::from_encoding(im.encoding).ok_or_else(|| {
                        format!("encoding {:?} is not 16UC1/mono16/32FC1", im.encoding)
                    })?;
                    if (im.width as usize, im.height as usize) != (w, hgt) {
                        return Err(format!(
                            "frame is {}x{}, the rig says {w}x{hgt}",
                            im.width, im.height
                        ));
                    }
                    let v =
                        ThermalView::new(im.data, w, hgt, im.step as usize, fmt, im.is_bigendian)?;
                    Ok((t, roi_maxima(&v, &self.rois, th.scale, th.offset_c)))
                }),
            COMPRESSED => compressed_image(ros1, data)
                .map_err(|e| format!("bad CompressedImage: {e}"))
                .and_then(|im| {
                    let t = if im.stamp_ns == 0 { log_t } else { im.stamp_ns };
                    let (pixels, bpp) = decode_png(im.format, im.data, (w, hgt))?;
                    if bpp != 2 {
                        return Err("thermal PNG must be 16-bit grey".into());
                    }
                    let v = ThermalView::new(
                        &pixels,
                        w,
                        hgt,
                        w * 2,
                        ThermalFormat::U16,
                        cfg!(target_endian = "big"),
                    )?;
                    Ok((t, roi_maxima(&v, &self.rois, th.scale, th.offset_c)))
                }),
            s => Err(format!("schema {s:?} is not an image")),
        };
        match res {
            Ok((t, maxima)) => {
                let tt = &mut part.tables.thermal;
                for (i, m) in maxima.iter().enumerate() {
                    tt.t_ns.push(t);
                    tt.roi.push(i as u32);
                    tt.max_c.push(m.max_c);
                    tt.peak_c.push(m.peak_c);
                    tt.x_px.push(m.x_px);
                    tt.y_px.push(m.y_px);
                }
            }
            Err(reason) => part.report.skip(topic, reason),
        }
    }
}

/// The message parsed from its serialization: CDR, or ROS 1's (`ros1`).
fn image(ros1: bool, data: &[u8]) -> std::result::Result<crate::msg::ImageMsg<'_>, String> {
    if ros1 {
        crate::ros1::parse_image(data)
    } else {
        cdr::parse_image(data).map_err(|e| e.to_string())
    }
}

fn compressed_image(
    ros1: bool,
    data: &[u8],
) -> std::result::Result<crate::msg::CompressedImageMsg<'_>, String> {
    if ros1 {
        crate::ros1::parse_compressed_image(data)
    } else {
        cdr::parse_compressed_image(data).map_err(|e| e.to_string())
    }
}

fn joint_state(
    ros1: bool,
    data: &[u8],
) -> std::result::Result<crate::msg::JointStateMsg<'_>, String> {
    if ros1 {
        crate::ros1::parse_joint_state(data)
    } else {
        cdr::parse_joint_state(data).map_err(|e| e.to_string())
    }
}

fn temperature(ros1: bool, data: &[u8]) -> std::result::Result<crate::msg::TemperatureMsg, String> {
    if ros1 {
        crate::ros1::parse_temperature(data)
    } else {
        cdr::parse_temperature(data).map_err(|e| e.to_string())
    }
}
