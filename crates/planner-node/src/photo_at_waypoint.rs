//! Nav2's PhotoAtWaypoint task executor (`photo_at_waypoint`): a patrol's photo at each
//! waypoint it reaches, what an inspection robot stops there for (a gauge, a cabinet's
//! indicator lights, a meter in a substation).
//!
//! The camera's frames ([`receive`]) are counted and the latest kept; at a waypoint, after the
//! pause, the patrol waits until a frame has come since its arrival (patrol.rs: Nav2 takes the
//! latest frame whenever it came, which may show the aisle on the way), then [`save`] writes
//! the latest as a PNG, `<save_dir>/<index>_<seconds>.png`.
//! A frame the node cannot read (an encoding it does not know, a size its data does not fill,
//! more pixels than [`MAX_PIXELS`]) or a folder it cannot write to fails the waypoint's task
//! with the reason, as Nav2's executor fails when cv_bridge or imwrite throws; the patrol goes
//! on as for any missed waypoint.

use crate::state::Shared;
use image::{DynamicImage, ImageBuffer, ImageFormat, Luma, Rgb, Rgba};
use log::{debug, info};
use patrol_msgs::sensor_msgs::Image;
use planner_io::parameters::PhotoAtWaypointParams;
use ros2_client::Subscription;
use std::io::Cursor;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// How long past the pause a patrol waits for a frame taken after its arrival: a camera
/// publishing at 1 Hz or faster gives one.
pub const FRAME_WAIT: Duration = Duration::from_secs(2);

/// The most pixels a frame may have (a 12-megapixel camera has 12 M): a frame beyond it is
/// refused, so no message can make the node encode without end.
pub const MAX_PIXELS: u64 = 50_000_000;

/// Keeps the latest frame on the camera's topic and counts the frames ([`Shared::camera`]).
pub async fn receive(s: Arc<Shared>, topic: String, sub: Subscription<Image>) {
    loop {
        match sub.async_take().await {
            Ok((frame, _)) => {
                let mut camera = s.camera.lock().expect("lock");
                camera.0 += 1;
                camera.1 = Some(Arc::new(frame));
            }
            Err(e) => debug!("{topic}: a frame that does not decode: {e:?}"),
        }
    }
}

/// Saves the latest frame as waypoint `index`'s photo; returns the file written, or why not.
pub async fn save(
    s: &Shared,
    params: &PhotoAtWaypointParams,
    index: usize,
) -> Result<PathBuf, String> {
    let frame = s
        .camera
        .lock()
        .expect("lock")
        .1
        .clone()
        .ok_or_else(|| format!("no frame on {}", params.image_topic))?;
    let dir = PathBuf::from(&params.save_dir);
    let name = format!("{index}_{}.png", ros_edge::now().sec);
    // Encoding a camera frame takes milliseconds to tens of them: off the async threads.
    let path = tokio::task::spawn_blocking(move || {
        let png = png_from_frame(&frame)?;
        std::fs::create_dir_all(&dir).map_err(|e| format!("cannot make {}: {e}", dir.display()))?;
        let file = dir.join(name);
        std::fs::write(&file, png).map_err(|e| format!("cannot write {}: {e}", file.display()))?;
        Ok::<_, String>(file)
    })
    .await
    .map_err(|e| format!("photo task: {e}"))??;
    info!("photo at waypoint {index}: {}", path.display());
    Ok(path)
}

/// A frame as a PNG file's bytes. The encodings cv_bridge gives Nav2's executor most often:
/// `rgb8`, `bgr8`, `rgba8`, `bgra8`, `mono8` (and its `8UC1`), and `mono16` and `16UC1` (a
/// depth image, kept at 16 bits) in either byte order; rows `step` bytes apart, at least a
/// row's pixels each.
pub fn png_from_frame(frame: &Image) -> Result<Vec<u8>, String> {
    let (width, height) = (frame.width, frame.height);
    let channels: u32 = match frame.encoding.as_str() {
        "rgb8" | "bgr8" => 3,
        "rgba8" | "bgra8" => 4,
        "mono8" | "8UC1" => 1,
        "mono16" | "16UC1" => 2,
        other => {
            return Err(format!(
            "encoding `{other}`: this node saves rgb8, bgr8, rgba8, bgra8, mono8, 8UC1, mono16 and 16UC1"
        ))
        }
    };
    let pixels = u64::from(width) * u64::from(height);
    if width == 0 || height == 0 || pixels > MAX_PIXELS {
        return Err(format!(
            "{width} x {height} pixels: at least one, at most {MAX_PIXELS}"
        ));
    }
    let row = u64::from(width) * u64::from(channels);
    let step = u64::from(frame.step);
    // The last row needs only its pixels, not a whole step.
    let needed = step * u64::from(height - 1) + row;
    if step < row || (frame.data.len() as u64) < needed {
        return Err(format!(
            "step {step} and {} bytes of data do not hold {height} rows of {row} bytes",
            frame.data.len()
        ));
    }
    // The rows packed, without the step's padding.
    let packed: Vec<u8> = frame
        .data
        .chunks(step as usize)
        .take(height as usize)
        .flat_map(|r| &r[..row as usize])
        .copied()
        .collect();
    let bad = || "the data does not fill the frame".to_string();
    let image = match frame.encoding.as_str() {
        "rgb8" => DynamicImage::ImageRgb8(
            ImageBuffer::<Rgb<u8>, _>::from_raw(width, height, packed).ok_or_else(bad)?,
        ),
        "bgr8" => DynamicImage::ImageRgb8(
            ImageBuffer::<Rgb<u8>, _>::from_raw(width, height, swap_red_blue(packed, 3))
                .ok_or_else(bad)?,
        ),
        "rgba8" => DynamicImage::ImageRgba8(
            ImageBuffer::<Rgba<u8>, _>::from_raw(width, height, packed).ok_or_else(bad)?,
        ),
        "bgra8" => DynamicImage::ImageRgba8(
            ImageBuffer::<Rgba<u8>, _>::from_raw(width, height, swap_red_blue(packed, 4))
                .ok_or_else(bad)?,
        ),
        "mono8" | "8UC1" => DynamicImage::ImageLuma8(
            ImageBuffer::<Luma<u8>, _>::from_raw(width, height, packed).ok_or_else(bad)?,
        ),
        _ => {
            let words = packed
                .chunks_exact(2)
                .map(|b| {
                    if frame.is_bigendian != 0 {
                        u16::from_be_bytes([b[0], b[1]])
                    } else {
                        u16::from_le_bytes([b[0], b[1]])
                    }
                })
                .collect();
            DynamicImage::ImageLuma16(
                ImageBuffer::<Luma<u16>, _>::from_raw(width, height, words).ok_or_else(bad)?,
            )
        }
    };
    let mut png = Vec::new();
    image
        .write_to(&mut Cursor::new(&mut png), ImageFormat::Png)
        .map_err(|e| format!("PNG: {e}"))?;
    Ok(png)
}

/// BGR(A) pixels as RGB(A): each pixel's first and third bytes swapped.
fn swap_red_blue(mut bytes: Vec<u8>, channels: usize) -> Vec<u8> {
    for pixel in bytes.chunks_exact_mut(channels) {
        pixel.swap(0, 2);
    }
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(encoding: &str, width: u32, height: u32, step: u32, data: Vec<u8>) -> Image {
        Image {
            encoding: encoding.into(),
            width,
            height,
            step,
            data,
            ..Image::default()
        }
    }

    fn decoded(png: &[u8]) -> DynamicImage {
        image::load_from_memory_with_format(png, ImageFormat::Png).unwrap()
    }

    /// Colours come out as the camera saw them: a BGR frame's first byte is blue; the step's
    /// padding is dropped and the last row may stop at its pixels.
    #[test]
    fn frames_are_saved_in_their_own_colours() {
        // 2 x 2, step 8 (2 bytes of padding a row), the last row without its padding.
        let bgr = frame(
            "bgr8",
            2,
            2,
            8,
            vec![255, 0, 0, 0, 255, 0, 9, 9, 0, 0, 255, 1, 2, 3],
        );
        let rgb = decoded(&png_from_frame(&bgr).unwrap()).to_rgb8();
        assert_eq!(rgb.get_pixel(0, 0).0, [0, 0, 255], "blue");
        assert_eq!(rgb.get_pixel(1, 0).0, [0, 255, 0], "green");
        assert_eq!(rgb.get_pixel(0, 1).0, [255, 0, 0], "red");
        assert_eq!(rgb.get_pixel(1, 1).0, [3, 2, 1]);
        let same = frame("rgb8", 1, 1, 3, vec![10, 20, 30]);
        assert_eq!(
            decoded(&png_from_frame(&same).unwrap())
                .to_rgb8()
                .get_pixel(0, 0)
                .0,
            [10, 20, 30]
        );
        let bgra = frame("bgra8", 1, 1, 4, vec![10, 20, 30, 40]);
        assert_eq!(
            decoded(&png_from_frame(&bgra).unwrap())
                .to_rgba8()
                .get_pixel(0, 0)
                .0,
            [30, 20, 10, 40]
        );
        // A depth frame keeps its 16 bits, in its byte order.
        let depth = |big| Image {
            is_bigendian: big,
            ..frame("16UC1", 1, 1, 2, vec![0x12, 0x34])
        };
        let word = |f: &Image| {
            decoded(&png_from_frame(f).unwrap())
                .to_luma16()
                .get_pixel(0, 0)
                .0[0]
        };
        assert_eq!((word(&depth(0)), word(&depth(1))), (0x3412, 0x1234));
        assert_eq!(
            decoded(&png_from_frame(&frame("mono8", 2, 1, 2, vec![7, 8])).unwrap())
                .to_luma8()
                .into_raw(),
            vec![7, 8]
        );
    }

    /// A frame the node cannot read is refused with the reason, never a panic.
    #[test]
    fn frames_that_do_not_hold_together_are_refused() {
        for (f, word) in [
            (frame("yuv422", 1, 1, 2, vec![0; 2]), "encoding `yuv422`"),
            (frame("rgb8", 0, 1, 0, vec![]), "pixels"),
            (frame("rgb8", 100_000, 100_000, 300_000, vec![]), "pixels"),
            (frame("rgb8", 2, 2, 5, vec![0; 12]), "do not hold"),
            (frame("rgb8", 2, 2, 6, vec![0; 11]), "do not hold"),
            (frame("mono16", u32::MAX, 1, u32::MAX, vec![]), "pixels"),
        ] {
            let err = png_from_frame(&f).unwrap_err();
            assert!(err.contains(word), "{err}");
        }
    }
}
