//! A uniform grid over a point set for fixed-radius neighbour queries, and voxel
//! subsampling. Building is a counting sort (O(points)); a query visits the 27 cells
//! around the query point, so the cost of a correspondence step stays linear in the number
//! of points when the cutoff radius is a few kernel widths.

use crate::math::Point3;

/// Points bucketed into cubic cells of one size.
#[derive(Clone, Debug, Default)]
pub struct PointGrid {
    origin: Point3,
    cell: f64,
    dims: [usize; 3],
    /// `starts[c]..starts[c + 1]` indexes `order` for cell `c`.
    starts: Vec<u32>,
    /// Point indices sorted by cell, and the points in that order (a query reads them in
    /// sequence, not scattered).
    order: Vec<u32>,
    sorted: Vec<Point3>,
    /// Scratch for building: (point, cell) and fill positions.
    keys: Vec<(u32, usize)>,
    fill: Vec<u32>,
}

/// The most cells a grid allocates per point (at least [`MIN_CELLS`]); coarser cells
/// are used beyond it, so a few far points cannot make the grid huge.
const CELLS_PER_POINT: usize = 8;
const MIN_CELLS: usize = 4096;

impl PointGrid {
    /// A grid over `points` whose cells are at least `cell` wide (wider when the points
    /// spread over too many cells). Non-finite points are left out.
    pub fn new(points: &[Point3], cell: f64) -> Self {
        let mut grid = Self::default();
        grid.rebuild(points, cell);
        grid
    }

    /// Builds the grid again over `points`, reusing storage.
    pub fn rebuild(&mut self, points: &[Point3], cell: f64) {
        let finite = || points.iter().filter(|p| p.iter().all(|c| c.is_finite()));
        let mut lo = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut hi = -lo;
        for p in finite() {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        self.order.clear();
        self.sorted.clear();
        self.starts.clear();
        if lo.x > hi.x {
            self.dims = [0; 3];
            self.starts.push(0);
            return;
        }
        let extent = hi - lo;
        let mut cell = if cell.is_finite() && cell > 0.0 {
            cell
        } else {
            extent.max().max(1e-12)
        };
        // `as usize` saturates, and so do the sum and the product: a cell far smaller than
        // the extent asks for more cells than there are, never an overflow.
        let dims = |cell: f64| extent.map(|e| ((e / cell).floor() as usize).saturating_add(1));
        let cells =
            |d: nalgebra::Vector3<usize>| d.iter().fold(1usize, |a, &b| a.saturating_mul(b));
        let max_cells = (CELLS_PER_POINT * points.len()).max(MIN_CELLS);
        while cells(dims(cell)) > max_cells {
            cell *= 2.0;
        }
        let d = dims(cell);
        self.origin = lo;
        self.cell = cell;
        self.dims = [d.x, d.y, d.z];
        let count = self.dims.iter().product::<usize>();
        self.starts.resize(count + 1, 0);
        let mut keys = std::mem::take(&mut self.keys);
        keys.clear();
        for (i, p) in points.iter().enumerate() {
            if let Some(c) = self.cell_of(p) {
                self.starts[c + 1] += 1;
                keys.push((i as u32, c));
            }
        }
        for c in 0..count {
            self.starts[c + 1] += self.starts[c];
        }
        self.order.resize(keys.len(), 0);
        let mut fill = std::mem::take(&mut self.fill);
        fill.clear();
        fill.extend_from_slice(&self.starts);
        for &(i, c) in &keys {
            self.order[fill[c] as usize] = i;
            fill[c] += 1;
        }
        self.sorted
            .extend(self.order.iter().map(|&i| points[i as usize]));
        self.keys = keys;
        self.fill = fill;
    }

    /// The cell size.
    pub fn cell(&self) -> f64 {
        self.cell
    }

    fn coords(&self, p: &Point3) -> [i64; 3] {
        let u = (p - self.origin) / self.cell;
        [floor_i64(u.x), floor_i64(u.y), floor_i64(u.z)]
    }

    fn cell_of(&self, p: &Point3) -> Option<usize> {
        if !p.iter().all(|c| c.is_finite()) {
            return None;
        }
        let c = self.coords(p);
        let inside = (0..3).all(|a| c[a] >= 0 && (c[a] as usize) < self.dims[a]);
        inside
            .then(|| (c[0] as usize * self.dims[1] + c[1] as usize) * self.dims[2] + c[2] as usize)
    }

    /// Calls `f(index, squared distance)` for every point within `radius` of `q`.
    pub fn for_each_within(&self, q: &Point3, radius: f64, mut f: impl FnMut(usize, f64)) {
        let r2 = radius * radius;
        self.runs_near(q, radius, |points, indices| {
            for (p, &i) in points.iter().zip(indices) {
                let d2 = (p - q).norm_squared();
                if d2 <= r2 {
                    f(i as usize, d2);
                }
            }
            false
        });
    }

    /// Whether any point lies within `radius` of `q` (stops at the first found).
    pub fn any_within(&self, q: &Point3, radius: f64) -> bool {
        let r2 = radius * radius;
        self.runs_near(q, radius, |points, _| {
            points.iter().any(|p| (p - q).norm_squared() <= r2)
        })
    }

    /// Calls `f(points, their indices)` on each run of consecutive cells that may hold
    /// points within `radius` of `q`, until `f` returns true; returns whether it did.
    fn runs_near(
        &self,
        q: &Point3,
        radius: f64,
        mut f: impl FnMut(&[Point3], &[u32]) -> bool,
    ) -> bool {
        if self.order.is_empty() || !q.iter().all(|c| c.is_finite()) {
            return false;
        }
        let reach = (radius / self.cell).ceil().max(1.0) as i64;
        let c = self.coords(q);
        let range = |a: usize| {
            let lo = (c[a] - reach).max(0);
            let hi = (c[a] + reach).min(self.dims[a] as i64 - 1);
            lo..=hi
        };
        for x in range(0) {
            for y in range(1) {
                let row = (x as usize * self.dims[1] + y as usize) * self.dims[2];
                let zs = range(2);
                if zs.is_empty() {
                    continue;
                }
                let (z0, z1) = (*zs.start() as usize, *zs.end() as usize);
                let from = self.starts[row + z0] as usize;
                let to = self.starts[row + z1 + 1] as usize;
                if f(&self.sorted[from..to], &self.order[from..to]) {
                    return true;
                }
            }
        }
        false
    }

    /// The nearest point within `radius` of `q` and its squared distance.
    pub fn nearest_within(&self, q: &Point3, radius: f64) -> Option<(usize, f64)> {
        let mut best: Option<(usize, f64)> = None;
        self.for_each_within(q, radius, |i, d2| {
            if best.is_none_or(|(_, b)| d2 < b) {
                best = Some((i, d2));
            }
        });
        best
    }
}

/// One representative per occupied cube of side `cell`: the first point met in it, and how
/// many points the cube holds, in the order of the representatives' indices. Non-finite
/// points are dropped.
pub fn voxel_subsample(points: &[Point3], cell: f64) -> Vec<(usize, u32)> {
    let Some(origin) = points.iter().find(|p| p.iter().all(|c| c.is_finite())) else {
        return Vec::new();
    };
    // Cube -> its slot in `out`; slots are taken in the order points are met.
    let mut slots: std::collections::HashMap<[i64; 3], u32, CellHasher> =
        std::collections::HashMap::with_capacity_and_hasher(points.len() / 2, CellHasher);
    let mut out: Vec<(usize, u32)> = Vec::with_capacity(points.len() / 2);
    for (i, p) in points.iter().enumerate() {
        let u = (p - origin) / cell;
        if !u.iter().all(|c| c.is_finite() && c.abs() < 1e15) {
            continue;
        }
        let key = [floor_i64(u.x), floor_i64(u.y), floor_i64(u.z)];
        let slot = *slots.entry(key).or_insert(out.len() as u32);
        match out.get_mut(slot as usize) {
            Some(rep) => rep.1 += 1,
            None => out.push((i, 1)),
        }
    }
    out
}

/// `x.floor() as i64` without the library call `floor` is on targets without SSE4.1: the
/// truncation, one less where it rounded up.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t - i64::from((t as f64) > x)
}

/// A hasher for integer cell coordinates (a multiply-rotate mix, as FxHash): the keys are
/// ours, so the standard library's collision-resistant SipHash is not needed.
#[derive(Clone, Copy, Debug, Default)]
struct CellHasher;

impl std::hash::BuildHasher for CellHasher {
    type Hasher = CellHash;
    fn build_hasher(&self) -> CellHash {
        CellHash(0)
    }
}

struct CellHash(u64);

impl std::hash::Hasher for CellHash {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    fn write_i64(&mut self, x: i64) {
        self.write_u64(x as u64);
    }
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn radius_queries_match_brute_force() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let points: Vec<Point3> = (0..500)
            .map(|_| Point3::new(rng.random(), rng.random(), rng.random::<f64>() * 0.2))
            .collect();
        for cell in [0.05, 0.1, 0.3] {
            let grid = PointGrid::new(&points, cell);
            for q in points.iter().take(50) {
                for radius in [0.04, 0.1, 0.25] {
                    let mut got = Vec::new();
                    grid.for_each_within(q, radius, |i, _| got.push(i));
                    got.sort_unstable();
                    let want: Vec<usize> = (0..points.len())
                        .filter(|&i| (points[i] - q).norm() <= radius)
                        .collect();
                    assert_eq!(got, want);
                    // Away from the points too: whether any lies within the radius.
                    let off = Point3::new(q.x + 0.07, q.y - 0.05, q.z + 0.3);
                    let any = points.iter().any(|p| (p - off).norm() <= radius);
                    assert_eq!(grid.any_within(q, radius), !want.is_empty());
                    assert_eq!(grid.any_within(&off, radius), any);
                }
            }
        }
    }

    #[test]
    fn subsample_counts_every_point_once() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(4);
        let points: Vec<Point3> = (0..1000)
            .map(|_| Point3::new(rng.random(), rng.random(), rng.random()))
            .collect();
        let reps = voxel_subsample(&points, 0.25);
        assert_eq!(reps.iter().map(|r| r.1 as usize).sum::<usize>(), 1000);
        assert!(reps.len() <= 125 && reps.len() > 20);
    }

    #[test]
    fn empty_and_non_finite_points() {
        let grid = PointGrid::new(&[], 0.1);
        assert!(grid.nearest_within(&Point3::origin(), 1.0).is_none());
        assert!(!grid.any_within(&Point3::origin(), 1.0));
        let grid = PointGrid::new(&[Point3::new(f64::NAN, 0.0, 0.0), Point3::origin()], 0.1);
        assert_eq!(grid.nearest_within(&Point3::origin(), 1.0), Some((1, 0.0)));
    }
}
