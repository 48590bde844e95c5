//! The occupancy grid, with nav_msgs/OccupancyGrid semantics.
//!
//! Cells hold `-1` (unknown) or an occupancy probability `0..=100`, row-major from the cell at the
//! origin (bottom-left in ROS's convention), exactly like `nav_msgs/OccupancyGrid.data`. A cell is
//! an obstacle at or above `occupied_threshold`; unknown is an obstacle unless `allow_unknown`
//! (both live in [`crate::grid::inflation::InflationConfig`], which turns this raw map into the planning
//! grid).

use crate::geometry::{Cell, Point2, Pose2};
use serde::{Deserialize, Serialize};

/// The default cap on `width x height`: large enough for a 5 km x 5 km yard at 0.5 m, small enough
/// that a corrupt header cannot make the node allocate gigabytes.
pub const DEFAULT_MAX_CELLS: u64 = 100_000_000;

/// The finest resolution (m per cell) a map may have: below a millimetre a map is a unit error
/// (a resolution in km, a corrupted message), and plans densified at it would be huge.
pub const MIN_RESOLUTION: f64 = 1e-3;
/// The coarsest resolution (m per cell) a map may have.
pub const MAX_RESOLUTION: f64 = 100.0;
/// How far (m) a map's origin and far corner may lie from the frame's origin: a planet's worth of
/// SLAM map is far less; beyond it the coordinates lose the precision planning needs.
pub const MAX_EXTENT: f64 = 1e6;

/// Value of an unknown cell.
pub const UNKNOWN: i8 = -1;

/// Everything wrong a map can be. Each violation is its own variant so that callers (the node's
/// diagnostics, the CLI) can say exactly what was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MapError {
    #[error("map has zero size ({width} x {height})")]
    ZeroSize { width: u32, height: u32 },
    #[error(
        "map resolution {0} m is not a finite number within {MIN_RESOLUTION}..={MAX_RESOLUTION} m"
    )]
    BadResolution(f64),
    #[error("map origin ({x}, {y}, yaw {yaw}) is not finite or lies beyond {MAX_EXTENT} m")]
    BadOrigin { x: f64, y: f64, yaw: f64 },
    #[error("map extends {extent} m from its origin, beyond {MAX_EXTENT} m")]
    TooFar { extent: f64 },
    #[error("map data has {actual} cells but width x height = {expected}")]
    DataLength { expected: u64, actual: usize },
    #[error("map has {cells} cells, more than the limit of {limit}")]
    TooLarge { cells: u64, limit: u64 },
    #[error("map cell {index} holds {value}, outside -1..=100")]
    BadCellValue { index: usize, value: i8 },
    #[error("map file: {0}")]
    Format(String),
}

/// The metadata of a grid: nav_msgs/MapMetaData without the load time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapInfo {
    pub width: u32,
    pub height: u32,
    /// Metres per cell.
    pub resolution: f64,
    /// The pose of cell (0, 0)'s outer corner in the map frame.
    pub origin: Pose2,
}

impl MapInfo {
    pub fn cell_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// World metres -> continuous grid coordinates (cells), honouring the origin's yaw.
    pub fn world_to_grid(&self, p: Point2) -> Point2 {
        let (s, c) = self.origin.yaw.sin_cos();
        let dx = p.x - self.origin.x;
        let dy = p.y - self.origin.y;
        Point2::new(
            (c * dx + s * dy) / self.resolution,
            (-s * dx + c * dy) / self.resolution,
        )
    }

    /// Continuous grid coordinates -> world metres.
    pub fn grid_to_world(&self, g: Point2) -> Point2 {
        let (s, c) = self.origin.yaw.sin_cos();
        let gx = g.x * self.resolution;
        let gy = g.y * self.resolution;
        Point2::new(
            self.origin.x + c * gx - s * gy,
            self.origin.y + s * gx + c * gy,
        )
    }

    /// The cell containing a world point, or `None` when it lies outside the map.
    pub fn world_to_cell(&self, p: Point2) -> Option<Cell> {
        let g = self.world_to_grid(p);
        let c = Cell::containing(g);
        self.contains(c).then_some(c)
    }

    /// The centre of a cell in world metres.
    pub fn cell_to_world(&self, c: Cell) -> Point2 {
        self.grid_to_world(c.center())
    }

    pub fn contains(&self, c: Cell) -> bool {
        c.x >= 0 && c.y >= 0 && (c.x as u32) < self.width && (c.y as u32) < self.height
    }

    /// Row-major index of a cell known to be inside the map.
    #[inline]
    pub fn index(&self, c: Cell) -> usize {
        c.y as usize * self.width as usize + c.x as usize
    }

    /// The cell at a row-major index.
    #[inline]
    pub fn cell_at(&self, index: usize) -> Cell {
        let w = self.width as usize;
        Cell::new((index % w) as i32, (index / w) as i32)
    }

    /// Checks the metadata alone, so a parser can refuse a map before it allocates its cells:
    /// non-zero size, at most `max_cells` cells, a resolution within
    /// [`MIN_RESOLUTION`]..=[`MAX_RESOLUTION`], an origin and extent within [`MAX_EXTENT`].
    pub fn validate(&self, max_cells: u64) -> Result<(), MapError> {
        if self.width == 0 || self.height == 0 {
            return Err(MapError::ZeroSize {
                width: self.width,
                height: self.height,
            });
        }
        if !(MIN_RESOLUTION..=MAX_RESOLUTION).contains(&self.resolution) {
            return Err(MapError::BadResolution(self.resolution));
        }
        if !self.origin.is_finite()
            || self.origin.x.abs() > MAX_EXTENT
            || self.origin.y.abs() > MAX_EXTENT
        {
            let o = self.origin;
            return Err(MapError::BadOrigin {
                x: o.x,
                y: o.y,
                yaw: o.yaw,
            });
        }
        let cells = self.width as u64 * self.height as u64;
        if cells > max_cells {
            return Err(MapError::TooLarge {
                cells,
                limit: max_cells,
            });
        }
        let extent = self.width.max(self.height) as f64 * self.resolution;
        if extent > MAX_EXTENT {
            return Err(MapError::TooFar { extent });
        }
        Ok(())
    }
}

/// A validated occupancy grid. The only way to build one is [`GridMap::new`] (or a parser that
/// calls it), so every `GridMap` in the program is well formed.
#[derive(Clone, Debug, PartialEq)]
pub struct GridMap {
    info: MapInfo,
    data: Vec<i8>,
}

impl GridMap {
    /// Validates and builds a map with the default size cap.
    pub fn new(info: MapInfo, data: Vec<i8>) -> Result<Self, MapError> {
        Self::with_limit(info, data, DEFAULT_MAX_CELLS)
    }

    /// Validates and builds a map: non-zero size, finite positive resolution, finite origin,
    /// at most `max_cells` cells, `data.len() == width * height`, every value in `-1..=100`.
    pub fn with_limit(info: MapInfo, data: Vec<i8>, max_cells: u64) -> Result<Self, MapError> {
        info.validate(max_cells)?;
        let expected = info.width as u64 * info.height as u64;
        if data.len() as u64 != expected {
            return Err(MapError::DataLength {
                expected,
                actual: data.len(),
            });
        }
        if let Some((index, &value)) = data
            .iter()
            .enumerate()
            .find(|(_, &v)| !(-1..=100).contains(&v))
        {
            return Err(MapError::BadCellValue { index, value });
        }
        Ok(Self { info, data })
    }

    pub fn info(&self) -> &MapInfo {
        &self.info
    }

    /// The same cells placed elsewhere: `origin` replaces the origin (a mask given in another
    /// frame, placed in the map's), checked as every origin is.
    pub fn placed_at(self, origin: Pose2) -> Result<Self, MapError> {
        let info = MapInfo {
            origin,
            ..self.info
        };
        info.validate(u64::MAX)?;
        Ok(Self {
            info,
            data: self.data,
        })
    }

    pub fn data(&self) -> &[i8] {
        &self.data
    }

    pub fn width(&self) -> u32 {
        self.info.width
    }

    pub fn height(&self) -> u32 {
        self.info.height
    }

    /// The raw value of a cell inside the map.
    pub fn value(&self, c: Cell) -> i8 {
        self.data[self.info.index(c)]
    }

    /// The map at `factor` times its resolution, cell for cell a grid downsampled by `factor`
    /// (`downsampling_factor`; the planning grid itself is inflated at full resolution first,
    /// `PlanningGrid::downsampled`): each block of `factor x factor` cells becomes one cell
    /// holding the block's worst value, so that a drawing or a published costmap loses nothing
    /// the robot must avoid. Worst first: an obstacle (a value at or above `obstacle_at`; the
    /// block keeps the highest), then unknown, then the highest free value. Same origin; the
    /// blocks along the far edges take the cells there are, so the coarse map reaches up to a
    /// coarse cell past this one's far edges. Factor 1 (or 0) is the map itself.
    pub fn downsampled(&self, factor: u32, obstacle_at: i8) -> Result<GridMap, MapError> {
        if factor <= 1 {
            return Ok(self.clone());
        }
        let (w, h) = (self.info.width, self.info.height);
        let info = MapInfo {
            width: w.div_ceil(factor),
            height: h.div_ceil(factor),
            resolution: self.info.resolution * factor as f64,
            origin: self.info.origin,
        };
        // A rank per value, worst highest: obstacles above unknown above free.
        let rank = |v: i8| -> i16 {
            if v >= obstacle_at {
                300 + v as i16
            } else if v == UNKNOWN {
                200
            } else {
                v as i16
            }
        };
        let mut data = vec![0i8; info.cell_count()];
        let (k, w, h) = (factor as usize, w as usize, h as usize);
        for (by, row) in data.chunks_mut(info.width as usize).enumerate() {
            for (bx, out) in row.iter_mut().enumerate() {
                let (x0, y0) = (bx * k, by * k);
                let worst = (y0..(y0 + k).min(h))
                    .flat_map(|y| &self.data[y * w + x0..y * w + (x0 + k).min(w)])
                    .copied()
                    .max_by_key(|&v| rank(v));
                *out = worst.expect("every block holds at least one cell");
            }
        }
        GridMap::new(info, data)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(w: u32, h: u32) -> MapInfo {
        MapInfo {
            width: w,
            height: h,
            resolution: 0.05,
            origin: Pose2::default(),
        }
    }

    /// A map placed elsewhere keeps its cells; its cells are then found where the new origin
    /// puts them (turned a quarter: cell (1, 0) lies along the world's +y); an origin beyond
    /// the map limits is refused.
    #[test]
    fn a_map_placed_elsewhere_keeps_its_cells_at_the_new_place() {
        let map = GridMap::new(info(2, 1), vec![0, 100]).unwrap();
        let turned = Pose2::new(3.0, 4.0, std::f64::consts::FRAC_PI_2);
        let placed = map.clone().placed_at(turned).unwrap();
        assert_eq!(placed.data(), map.data());
        let c = placed
            .info()
            .world_to_cell(Point2::new(2.975, 4.075))
            .unwrap();
        assert_eq!((c, placed.value(c)), (Cell::new(1, 0), 100));
        let far = Pose2::new(2.0 * MAX_EXTENT, 0.0, 0.0);
        assert!(matches!(
            map.placed_at(far),
            Err(MapError::BadOrigin { .. })
        ));
    }

    #[test]
    fn a_downsampled_map_keeps_each_blocks_worst_cell() {
        // 5 x 3 at 0.05 m, by 2: 3 x 2 blocks, the last column and row partial.
        #[rustfmt::skip]
        let data = vec![
            0, -1, -1, 0, 0,
            0, 70, 0, 0, 5,
            -1, 0, 0, 0, 100,
        ];
        let map = GridMap::new(info(5, 3), data).unwrap();
        let coarse = map.downsampled(2, 65).unwrap();
        assert_eq!((coarse.width(), coarse.height()), (3, 2));
        assert!((coarse.info().resolution - 0.1).abs() < 1e-12);
        assert_eq!(coarse.info().origin, map.info().origin);
        // An obstacle beats unknown and free; unknown beats free; else the highest free value.
        assert_eq!(coarse.data(), &[70, -1, 5, -1, 0, 100]);
        // Below the threshold 70 is a free value, and unknown beats it.
        assert_eq!(map.downsampled(2, 80).unwrap().data()[0], -1);
        assert_eq!(map.downsampled(1, 65).unwrap(), map);
        // Too coarse a resolution is refused as any map's would be.
        let mut wide = info(4, 4);
        wide.resolution = 60.0;
        let wide = GridMap::new(wide, vec![0; 16]).unwrap();
        assert!(matches!(
            wide.downsampled(2, 65),
            Err(MapError::BadResolution(_))
        ));
    }

    #[test]
    fn each_violation_is_its_own_error() {
        assert_eq!(
            GridMap::new(info(0, 3), vec![]),
            Err(MapError::ZeroSize {
                width: 0,
                height: 3
            })
        );
        let mut bad = info(2, 2);
        bad.resolution = 0.0;
        assert_eq!(
            GridMap::new(bad, vec![0; 4]),
            Err(MapError::BadResolution(0.0))
        );
        bad.resolution = f64::NAN;
        assert!(matches!(
            GridMap::new(bad, vec![0; 4]),
            Err(MapError::BadResolution(_))
        ));
        let mut bad = info(2, 2);
        bad.origin.yaw = f64::INFINITY;
        assert!(matches!(
            GridMap::new(bad, vec![0; 4]),
            Err(MapError::BadOrigin { .. })
        ));
        assert_eq!(
            GridMap::new(info(2, 2), vec![0; 3]),
            Err(MapError::DataLength {
                expected: 4,
                actual: 3
            })
        );
        assert_eq!(
            GridMap::with_limit(info(10, 10), vec![0; 100], 99),
            Err(MapError::TooLarge {
                cells: 100,
                limit: 99
            })
        );
        assert_eq!(
            GridMap::new(info(2, 1), vec![0, 101]),
            Err(MapError::BadCellValue {
                index: 1,
                value: 101
            })
        );
        assert!(GridMap::new(info(2, 2), vec![-1, 0, 50, 100]).is_ok());
    }

    proptest::proptest! {
        /// world -> cell -> world lands within half a cell (on each grid axis) of where it started,
        /// for any origin yaw.
        #[test]
        fn world_cell_world_round_trip(
            ox in -50.0f64..50.0, oy in -50.0f64..50.0, yaw in -3.2f64..3.2, res in 0.01f64..2.0,
            fx in 0.0f64..1.0, fy in 0.0f64..1.0,
        ) {
            let i = MapInfo { width: 40, height: 30, resolution: res, origin: Pose2::new(ox, oy, yaw) };
            let p = i.grid_to_world(Point2::new(fx * 40.0, fy * 30.0));
            let c = i.world_to_cell(p).expect("inside by construction");
            let back = i.cell_to_world(c);
            let g0 = i.world_to_grid(p);
            let g1 = i.world_to_grid(back);
            proptest::prop_assert!((g0.x - g1.x).abs() <= 0.5 + 1e-9 && (g0.y - g1.y).abs() <= 0.5 + 1e-9);
            proptest::prop_assert!((p - back).norm() <= res * std::f64::consts::FRAC_1_SQRT_2 + 1e-9);
        }
    }

    #[test]
    fn transforms_honour_yaw() {
        let i = MapInfo {
            width: 10,
            height: 10,
            resolution: 0.5,
            origin: Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2),
        };
        // Grid +x points along world +y when the origin is turned by 90 degrees.
        let w = i.grid_to_world(Point2::new(2.0, 0.0));
        assert!((w.x - 1.0).abs() < 1e-12 && (w.y - 3.0).abs() < 1e-12);
        let g = i.world_to_grid(w);
        assert!((g.x - 2.0).abs() < 1e-12 && g.y.abs() < 1e-12);
        assert_eq!(i.world_to_cell(Point2::new(0.0, 0.0)), None);
        assert_eq!(
            i.world_to_cell(Point2::new(0.9, 2.1)),
            Some(Cell::new(0, 0))
        );
    }
}
