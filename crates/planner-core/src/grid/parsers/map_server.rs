//! ROS map_server maps: a YAML description plus a PGM/PNG image, decoded exactly as Nav2's
//! `nav2_map_server/map_io.cpp` does, so a map loads here as it would in a Nav2 stack.
//!
//! Per pixel: `shade` = mean of the R, G, B channels in 0..1 (in trinary mode an alpha channel is
//! averaged in too, as ROS 1's map_server did and Nav2 keeps "to preserve existing behavior"); `occ` = `1 - shade` (or `shade` with `negate`). Then
//! - trinary: `occ > occupied_thresh` -> 100, `occ < free_thresh` -> 0, else -1;
//! - scale: a transparent pixel -> -1, thresholds as trinary, in between scaled linearly to 0..100;
//! - raw: the grey value 0..255 itself when it is 0..=100, else -1.
//!
//! Image row 0 is the top of the picture; grid row 0 is the bottom, so rows are flipped.

use crate::geometry::Pose2;
use crate::grid::map::{GridMap, MapError, MapInfo, DEFAULT_MAX_CELLS, UNKNOWN};
use serde::Deserialize;

/// How pixel values become occupancy values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    #[default]
    Trinary,
    Scale,
    Raw,
}

/// The YAML half of a map_server map.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct MapYaml {
    /// The image file, relative to the YAML file's folder unless absolute.
    pub image: String,
    #[serde(default)]
    pub mode: Mode,
    pub resolution: f64,
    /// `[x, y, yaw]` of the bottom-left pixel's outer corner.
    pub origin: [f64; 3],
    #[serde(default, deserialize_with = "flag")]
    pub negate: bool,
    #[serde(default = "default_occupied_thresh")]
    pub occupied_thresh: f64,
    #[serde(default = "default_free_thresh")]
    pub free_thresh: f64,
}

fn default_occupied_thresh() -> f64 {
    0.65
}

fn default_free_thresh() -> f64 {
    0.196
}

/// map_server writes `negate: 0`; people write `negate: false`. Accept both.
fn flag<'de, D: serde::Deserializer<'de>>(d: D) -> Result<bool, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Flag {
        Bool(bool),
        Int(i64),
    }
    Ok(match Flag::deserialize(d)? {
        Flag::Bool(b) => b,
        Flag::Int(i) => i != 0,
    })
}

impl MapYaml {
    /// Parses and checks the YAML text.
    pub fn parse(text: &[u8]) -> Result<Self, MapError> {
        input_guard::yaml::check(text).map_err(|e| MapError::Format(format!("map yaml: {e}")))?;
        let y: MapYaml =
            serde_yaml::from_slice(text).map_err(|e| MapError::Format(format!("map yaml: {e}")))?;
        if !(y.resolution.is_finite() && y.resolution > 0.0) {
            return Err(MapError::BadResolution(y.resolution));
        }
        if y.image.trim().is_empty() {
            return Err(MapError::Format("map yaml: `image` is empty".into()));
        }
        let thresholds_ok = (0.0..=1.0).contains(&y.free_thresh)
            && (0.0..=1.0).contains(&y.occupied_thresh)
            && y.free_thresh < y.occupied_thresh;
        if !thresholds_ok {
            return Err(MapError::Format(format!(
                "map yaml: thresholds must satisfy 0 <= free_thresh ({}) < occupied_thresh ({}) <= 1",
                y.free_thresh, y.occupied_thresh
            )));
        }
        Ok(y)
    }

    /// Decodes the image bytes into a grid with this YAML's metadata.
    pub fn decode(&self, image_bytes: &[u8]) -> Result<GridMap, MapError> {
        self.decode_with_limit(image_bytes, DEFAULT_MAX_CELLS)
    }

    pub fn decode_with_limit(
        &self,
        image_bytes: &[u8],
        max_cells: u64,
    ) -> Result<GridMap, MapError> {
        let image_err =
            |e: image::ImageError| MapError::Format(format!("map image `{}`: {e}", self.image));
        // The image's header chooses the size: read the dimensions alone and check them (cell
        // cap, resolution, extent) before decoding a single pixel.
        let reader = || {
            image::ImageReader::new(std::io::Cursor::new(image_bytes))
                .with_guessed_format()
                .map_err(|e| MapError::Format(format!("map image `{}`: {e}", self.image)))
        };
        let (w, h) = reader()?.into_dimensions().map_err(image_err)?;
        let info = MapInfo {
            width: w,
            height: h,
            resolution: self.resolution,
            origin: Pose2::new(self.origin[0], self.origin[1], self.origin[2]),
        };
        info.validate(max_cells)?;
        let img = reader()?.decode().map_err(image_err)?;
        let has_alpha = img.color().has_alpha();
        let mut data = vec![UNKNOWN; w as usize * h as usize];
        let mut put = |x: u32, y: u32, px: [u16; 4]| {
            let [r, g, b, a] = px.map(|c| c as f64 / 65535.0);
            data[(h - 1 - y) as usize * w as usize + x as usize] =
                self.classify(r, g, b, a, has_alpha);
        };
        // 8-bit images (map_saver's PGMs, most PNGs) are read in place, widened per pixel as the
        // image crate widens them (v * 257), so no 16-bit RGBA copy of the map is ever made.
        let wide = |v: u8| v as u16 * 257;
        match &img {
            image::DynamicImage::ImageLuma8(px) => {
                for (x, y, p) in px.enumerate_pixels() {
                    let v = wide(p.0[0]);
                    put(x, y, [v, v, v, u16::MAX]);
                }
            }
            image::DynamicImage::ImageLumaA8(px) => {
                for (x, y, p) in px.enumerate_pixels() {
                    let v = wide(p.0[0]);
                    put(x, y, [v, v, v, wide(p.0[1])]);
                }
            }
            image::DynamicImage::ImageRgb8(px) => {
                for (x, y, p) in px.enumerate_pixels() {
                    put(x, y, [wide(p.0[0]), wide(p.0[1]), wide(p.0[2]), u16::MAX]);
                }
            }
            image::DynamicImage::ImageRgba8(px) => {
                for (x, y, p) in px.enumerate_pixels() {
                    put(x, y, p.0.map(wide));
                }
            }
            other => {
                for (x, y, p) in other.to_rgba16().enumerate_pixels() {
                    put(x, y, p.0);
                }
            }
        }
        GridMap::with_limit(info, data, max_cells)
    }

    /// One pixel (channels in 0..1) -> one occupancy value, as map_io.cpp does.
    fn classify(&self, r: f64, g: f64, b: f64, alpha: f64, has_alpha: bool) -> i8 {
        let shade = if self.mode == Mode::Trinary && has_alpha {
            (r + g + b + alpha) / 4.0
        } else {
            (r + g + b) / 3.0
        };
        let occ = if self.negate { shade } else { 1.0 - shade };
        match self.mode {
            Mode::Trinary => self.threshold(occ).unwrap_or(UNKNOWN),
            Mode::Scale => {
                if has_alpha && alpha < 1.0 {
                    UNKNOWN
                } else {
                    self.threshold(occ).unwrap_or_else(|| {
                        let t =
                            (occ - self.free_thresh) / (self.occupied_thresh - self.free_thresh);
                        (t * 100.0).round_ties_even() as i8
                    })
                }
            }
            Mode::Raw => {
                let v = (shade * 255.0).round();
                if (0.0..=100.0).contains(&v) {
                    v as i8
                } else {
                    UNKNOWN
                }
            }
        }
    }

    /// `Some(100)` above the occupied threshold, `Some(0)` below the free one, `None` between.
    fn threshold(&self, occ: f64) -> Option<i8> {
        if self.occupied_thresh < occ {
            Some(100)
        } else if occ < self.free_thresh {
            Some(0)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A binary PGM (P5) from rows listed top to bottom.
    fn pgm(rows: &[&[u8]]) -> Vec<u8> {
        let mut v = format!(
            "P5\n# made by a test\n{} {}\n255\n",
            rows[0].len(),
            rows.len()
        )
        .into_bytes();
        for r in rows {
            v.extend_from_slice(r);
        }
        v
    }

    fn yaml(extra: &str) -> MapYaml {
        MapYaml::parse(
            format!("image: m.pgm\nresolution: 0.05\norigin: [1.0, 2.0, 0.5]\n{extra}").as_bytes(),
        )
        .unwrap()
    }

    #[test]
    fn trinary_is_the_default_and_rows_are_flipped() {
        let y = yaml("");
        assert_eq!(y.mode, Mode::Trinary);
        // Top row: black, white; bottom row: grey (unknown), white.
        let m = y.decode(&pgm(&[&[0, 254], &[205, 255]])).unwrap();
        assert_eq!(m.data(), &[-1, 0, 100, 0]);
        assert_eq!(m.info().origin, Pose2::new(1.0, 2.0, 0.5));
    }

    #[test]
    fn negate_swaps_black_and_white() {
        let m = yaml("negate: 1").decode(&pgm(&[&[0, 255]])).unwrap();
        assert_eq!(m.data(), &[0, 100]);
        let m = yaml("negate: true").decode(&pgm(&[&[0, 255]])).unwrap();
        assert_eq!(m.data(), &[0, 100]);
    }

    #[test]
    fn scale_interpolates_between_thresholds() {
        let y = yaml("mode: scale\nfree_thresh: 0.2\noccupied_thresh: 0.8");
        // occ = 1 - 127/255 = 0.502 -> (0.502-0.2)/0.6*100 = 50.3 -> 50
        let m = y.decode(&pgm(&[&[0, 127, 255]])).unwrap();
        assert_eq!(m.data(), &[100, 50, 0]);
    }

    #[test]
    fn raw_keeps_values_up_to_100() {
        let m = yaml("mode: raw")
            .decode(&pgm(&[&[0, 42, 100, 101, 255]]))
            .unwrap();
        assert_eq!(m.data(), &[0, 42, 100, -1, -1]);
    }

    #[test]
    fn rgb_png_is_averaged_and_alpha_counts_in_trinary() {
        let mut img = image::RgbaImage::new(3, 1);
        img.put_pixel(0, 0, image::Rgba([255, 255, 255, 255])); // white, opaque: free
        img.put_pixel(1, 0, image::Rgba([0, 0, 0, 255])); // black: occupied
        img.put_pixel(2, 0, image::Rgba([255, 255, 255, 0])); // white, transparent: (3+0)/4 -> unknown
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        assert_eq!(yaml("").decode(&png).unwrap().data(), &[0, 100, -1]);
        // In scale mode any transparency is unknown.
        assert_eq!(
            yaml("mode: scale").decode(&png).unwrap().data(),
            &[0, 100, -1]
        );
    }

    #[test]
    fn malformed_inputs_are_format_errors() {
        let truncated = &pgm(&[&[0, 255], &[0, 255]])[..20];
        assert!(matches!(
            yaml("").decode(truncated),
            Err(MapError::Format(_))
        ));
        assert!(matches!(
            yaml("").decode(b"not an image"),
            Err(MapError::Format(_))
        ));
        assert!(matches!(
            MapYaml::parse(b"resolution: 0.05\norigin: [0,0,0]"),
            Err(MapError::Format(_))
        ));
        assert!(matches!(
            MapYaml::parse(b"image: a.pgm\nresolution: 0\norigin: [0,0,0]"),
            Err(MapError::BadResolution(_))
        ));
        assert!(matches!(
            MapYaml::parse(b"image: a.pgm\nresolution: 0.1\norigin: [0,0,0]\nfree_thresh: 0.9"),
            Err(MapError::Format(_))
        ));
        assert!(matches!(
            MapYaml::parse(b"image: a.pgm\nresolution: 0.1\norigin: [0,0,0]\nmode: fancy"),
            Err(MapError::Format(_))
        ));
    }

    #[test]
    fn size_cap_is_checked_before_decoding_cells() {
        let y = yaml("");
        assert!(matches!(
            y.decode_with_limit(&pgm(&[&[0, 0, 0]]), 2),
            Err(MapError::TooLarge { cells: 3, limit: 2 })
        ));
        // A PGM header that claims 100000 x 100000 pixels, with no pixels behind it: refused
        // from the header, not after decoding (or trying to).
        let huge = b"P5\n100000 100000\n255\n".to_vec();
        assert!(matches!(
            y.decode(&huge),
            Err(MapError::TooLarge {
                cells: 10_000_000_000,
                ..
            })
        ));
    }

    /// The in-place 8-bit paths classify every pixel exactly as the 16-bit RGBA conversion does,
    /// for each layout and mode (the thresholds are compared in floating point, so the widening
    /// must be the image crate's, bit for bit).
    #[test]
    fn eight_bit_layouts_match_the_sixteen_bit_reference() {
        use image::{DynamicImage, ImageFormat};
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (w, h) = (17u32, 9u32);
        let bytes = |n: usize, rng: &mut rand_chacha::ChaCha8Rng| -> Vec<u8> {
            (0..n).map(|_| rng.random()).collect()
        };
        let images = [
            DynamicImage::ImageLuma8(
                image::GrayImage::from_raw(w, h, bytes(153, &mut rng)).unwrap(),
            ),
            DynamicImage::ImageLumaA8(
                image::GrayAlphaImage::from_raw(w, h, bytes(306, &mut rng)).unwrap(),
            ),
            DynamicImage::ImageRgb8(image::RgbImage::from_raw(w, h, bytes(459, &mut rng)).unwrap()),
            DynamicImage::ImageRgba8(
                image::RgbaImage::from_raw(w, h, bytes(612, &mut rng)).unwrap(),
            ),
        ];
        for mode in ["trinary", "scale", "raw"] {
            let y = yaml(&format!("mode: {mode}\n"));
            for img in &images {
                let mut png = Vec::new();
                img.write_to(&mut std::io::Cursor::new(&mut png), ImageFormat::Png)
                    .unwrap();
                let map = y.decode(&png).unwrap();
                let has_alpha = img.color().has_alpha();
                for (x, yy, px) in img.to_rgba16().enumerate_pixels() {
                    let [r, g, b, a] = px.0.map(|c| c as f64 / 65535.0);
                    let want = y.classify(r, g, b, a, has_alpha);
                    assert_eq!(
                        map.data()[((h - 1 - yy) * w + x) as usize],
                        want,
                        "{mode} {:?} at ({x}, {yy})",
                        img.color()
                    );
                }
            }
        }
    }
}
