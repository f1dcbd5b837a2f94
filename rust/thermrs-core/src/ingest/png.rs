//! PNG frames (`sensor_msgs/CompressedImage`), decoded within the rig's frame size.

/// Decode a lossless PNG (8- or 16-bit grey) of the rig's frame size `(w, h)` to
/// native-endian pixel bytes: (bytes, bytes per pixel). The header's size is compared with the
/// rig's before anything is allocated, and the decoder runs with limits set from it (image
/// size and memory), so a crafted header or a decompression bomb costs at most one frame.
pub fn decode_png(
    format: &str,
    data: &[u8],
    (w, h): (usize, usize),
) -> std::result::Result<(Vec<u8>, usize), String> {
    use image::ImageDecoder;
    if !format.to_ascii_lowercase().contains("png") {
        return Err(format!("compressed format {format:?} is not PNG"));
    }
    // A 16-bit grey frame of the rig's size, and the decoder's own row buffers beside it.
    let frame = (w as u64).saturating_mul(h as u64).saturating_mul(2);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(u32::try_from(w).unwrap_or(u32::MAX));
    limits.max_image_height = Some(u32::try_from(h).unwrap_or(u32::MAX));
    limits.max_alloc = Some(frame.saturating_mul(2).saturating_add(1 << 20));
    let dec = match image::codecs::png::PngDecoder::with_limits(std::io::Cursor::new(data), limits)
    {
        Err(image::ImageError::Limits(_)) => {
            // Say what the header claims, read without decoding anything.
            return Err(match png_size(data) {
                Some((pw, ph)) => format!("frame is {pw}x{ph}, the rig says {w}x{h}"),
                None => format!("PNG larger than the rig's {w}x{h} frame"),
            });
        }
        Err(e) => return Err(format!("PNG: {e}")),
        Ok(d) => d,
    };
    let (pw, ph) = dec.dimensions();
    if (pw as usize, ph as usize) != (w, h) {
        return Err(format!("frame is {pw}x{ph}, the rig says {w}x{h}"));
    }
    let bpp = match dec.color_type() {
        image::ColorType::L8 => 1,
        image::ColorType::L16 => 2,
        c => return Err(format!("PNG colour type {c:?} is not 8- or 16-bit grey")),
    };
    let total = dec.total_bytes();
    if total > frame {
        return Err(format!(
            "PNG of {total} bytes is larger than the rig's frame"
        ));
    }
    let mut buf = vec![0u8; total as usize];
    dec.read_image(&mut buf).map_err(|e| format!("PNG: {e}"))?;
    Ok((buf, bpp))
}

/// Width and height from a PNG's IHDR chunk, without decoding.
fn png_size(data: &[u8]) -> Option<(u32, u32)> {
    let ihdr = data.get(12..24)?;
    if &ihdr[..4] != b"IHDR" {
        return None;
    }
    Some((
        u32::from_be_bytes(ihdr[4..8].try_into().ok()?),
        u32::from_be_bytes(ihdr[8..12].try_into().ok()?),
    ))
}
