//! Interpreting a unit of work: a chunk (in place or copied, decompressed, checksummed) or a
//! batch of loose messages, each message dispatched by its topic's role to the frame, thermal,
//! joint-state or ambient reader.

use mcap::records::{op, MessageHeader, Record};

use super::*;

impl<'r> Context<'r> {
    /// Interpret one message into `part`. Returns false if its channel is unknown.
    fn message(
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
        let Some(&role) = self.roles.get(ch.topic.as_str()) else {
            part.report.other_messages += 1;
            return true;
        };
        let topic = ch.topic.as_str();
        *part.report.messages.entry(topic.to_string()).or_insert(0) += 1;
        let schema = local
            .schemas
            .get(&ch.schema_id)
            .or_else(|| reg.schemas.get(&ch.schema_id))
            .map(String::as_str)
            .unwrap_or("");
        if ch.encoding != "cdr" {
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
            Role::Camera(i) => self.camera_frame(i, topic, schema, data, h, part),
            Role::Thermal => self.thermal_frame(topic, schema, data, h, part),
            Role::Joints => match (schema, cdr::parse_joint_state(data)) {
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
            Role::Ambient => match (schema, cdr::parse_temperature(data)) {
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

    fn camera_frame(
        &self,
        cam: usize,
        topic: &str,
        schema: &str,
        data: &[u8],
        h: &MessageHeader,
        part: &mut Part,
    ) {
        let c = &self.rig.camera[cam];
        let (w, hgt) = (c.size_px[0] as usize, c.size_px[1] as usize);
        let log_t = h.log_time as i64;
        let res: std::result::Result<(i64, centroid::Spot), String> = match schema {
            IMAGE => cdr::parse_image(data)
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
            COMPRESSED => cdr::parse_compressed_image(data)
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
        data: &[u8],
        h: &MessageHeader,
        part: &mut Part,
    ) {
        let Some(th) = &self.rig.thermal else { return };
        let (w, hgt) = (th.size_px[0] as usize, th.size_px[1] as usize);
        let log_t = h.log_time as i64;
        let res: std::result::Result<(i64, Vec<crate::thermal::RoiMax>), String> = match schema {
            IMAGE => cdr::parse_image(data)
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
            COMPRESSED => cdr::parse_compressed_image(data)
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

    /// Process one unit of work.
    pub(super) fn run(&self, reg: &Registry, work: &Work<'_>) -> Part {
        let mut part = Part::default();
        match work {
            Work::Loose(msgs) => {
                let local = Registry::default();
                for (h, d) in msgs {
                    if !self.message(reg, &local, h, d, &mut part) {
                        // Perhaps defined in a chunk of the same window: run again later.
                        part.retry = true;
                        part.report
                            .skip("?", format!("message on unknown channel {}", h.channel_id));
                    }
                }
            }
            Work::Chunk {
                offset,
                bytes,
                header,
                data,
                partial,
            } => {
                part.report.chunks = 1;
                let started = std::time::Instant::now();
                let mut timed = None;
                CHUNK_BUF.with(|cell| INPUT_BUF.with(|icell| {
                    let mut scratch = cell.borrow_mut();
                    let mut input = icell.borrow_mut();
                    // Read route: the chunk's records are copied window by window into a
                    // buffer that stays in cache (`walk_read`), not mapped.
                    let mut streamed = None;
                    match self.source {
                        Some(src) if header.compression.is_empty() && !*partial => {
                            let route = self.routes.pick();
                            timed = Some(route);
                            match route {
                                // Mapped in by the faults of the walk itself: one
                                // `MADV_POPULATE_READ` for the chunk costs more here (it
                                // maps page by page; a fault maps a folio's pages at once).
                                Route::Map => {}
                                Route::Read => streamed = Some(src),
                            }
                        }
                        Some(src) => src.populate(data),
                        None => {}
                    }
                    // Uncompressed chunks are walked in place.
                    let buf: &[u8] = if header.compression.is_empty() {
                        data
                    } else {
                        if let Err(e) = decompress(header, data, *partial, &mut scratch) {
                            part.report.losses.push(Loss::new(
                                "corrupt_chunk",
                                *offset,
                                *bytes,
                                format!("chunk at bytes {offset}..{} skipped: {e}", offset + bytes),
                            ));
                            return;
                        }
                        &scratch
                    };
                    // The CRC is taken record by record just before each is interpreted, so
                    // that its pass brings the frame into cache for the detector (one pass
                    // over memory, not two); a chunk that fails is dropped whole.
                    let check = self.verify_crc && !*partial && header.uncompressed_crc != 0;
                    let mut hasher = crc32fast::Hasher::new();
                    let mut hashed = 0usize;
                    let mut local = Registry::default();
                    let mut err: Option<String> = None;
                    let mut n = 0u64;
                    let visited = std::cell::Cell::new(0usize);
                    let mut visit = |at: usize, opcode: u8, body: &[u8], record: &[u8]| {
                        visited.set(visited.get() + 1);
                        if check {
                            hasher.update(record);
                            hashed = at + record.len();
                        }
                        match opcode {
                        op::SCHEMA | op::CHANNEL => match mcap::read::parse_record(opcode, body) {
                            Ok(r) => {
                                local.absorb(&r);
                                true
                            }
                            Err(e) => {
                                err = Some(format!("bad record: {e}"));
                                false
                            }
                        },
                        op::MESSAGE => match mcap::read::parse_record(opcode, body) {
                            Ok(Record::Message { header, data }) => {
                                n += 1;
                                if self.message(reg, &local, &header, &data, &mut part) {
                                    true
                                } else {
                                    part.retry = true;
                                    false
                                }
                            }
                            Ok(_) => true,
                            Err(e) => {
                                err = Some(format!("bad message record: {e}"));
                                false
                            }
                        },
                        _ => true,
                    }};
                    let read = streamed.map(|src| {
                        let (at, len) = src.range(data);
                        walk_read(src.file, at as u64, len, &mut input, &mut visit)
                    });
                    let (stop, failed) = match read {
                        Some(Ok(stop)) => (stop, None),
                        Some(Err(e)) if visited.get() > 0 => (Some(0), Some(e)),
                        // In place (or the read failed at once: the map has the same bytes).
                        _ => (
                            walk(buf, |at, opcode, body| {
                                visit(at, opcode, body, &buf[at..at + 9 + body.len()])
                            }),
                            None,
                        ),
                    };
                    if let Some(e) = failed {
                        err = Some(format!("read failed: {e}"));
                    }
                    if check && !part.retry {
                        hasher.update(&buf[hashed..]);
                        let crc = hasher.finalize();
                        if crc != header.uncompressed_crc {
                            part = Part::default();
                            part.report.chunks = 1;
                            part.report.crc_failures = 1;
                            let mut loss = Loss::new(
                                "corrupt_chunk",
                                *offset,
                                *bytes,
                                format!(
                                    "chunk at bytes {offset}..{} skipped: its CRC-32 is {crc:08x}, the header says {:08x}",
                                    offset + bytes,
                                    header.uncompressed_crc
                                ),
                            );
                            loss.channels_lost = recovery::count_messages(buf);
                            part.report.losses.push(loss);
                            return;
                        }
                    }
                    part.registry = local;
                    if part.retry {
                        return;
                    }
                    if let Some(e) = err {
                        part.report.losses.push(Loss::new(
                            "corrupt_chunk",
                            *offset,
                            *bytes,
                            format!("chunk at bytes {offset}..{}: {e}; {n} messages before it kept", offset + bytes),
                        ));
                    } else if stop.is_some() && !*partial {
                        part.report.losses.push(Loss::new(
                            "corrupt_chunk",
                            *offset,
                            *bytes,
                            format!("chunk at bytes {offset}..{} ends inside a record; {n} messages before it kept", offset + bytes),
                        ));
                    } else if *partial {
                        part.report.recovered_messages = n;
                    }
                }));
                if let (Some(route), Some(src)) = (timed, self.source) {
                    if route == Route::Map {
                        // Unmap the chunk's whole pages now, so that the cost is timed
                        // with its route (the window's ends are released by the walk).
                        let (from, len) = src.range(data);
                        let page = 4096;
                        src.release(from.div_ceil(page) * page, (from + len) / page * page);
                    }
                    self.routes.record(route, started.elapsed(), data.len());
                }
            }
        }
        part
    }
}
