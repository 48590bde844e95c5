//! The genetic algorithm paper's operators on chromosomes, which are continuous 8-connected
//! cell paths from the start to the goal: gap filling by median insertion (4.1, eq. 3) or by
//! random insertion (the plain GA), layered selection (4.3.1), single-point crossover at a
//! shared cell (4.3.2), the eight-neighbourhood mutation (4.3.3), and the reroute that replaces
//! it at scale. Pure functions of the grid and the random draws; the colonies' local search
//! reroutes their best ant with [`reroute`] too.

use crate::geometry::{Cell, NEIGHBOURS_8};
use crate::grid::PlanningGrid;
use rand::Rng;
use rustc_hash::{FxHashMap, FxHashSet};

/// A chromosome is valid when it runs from `start` to `goal` through free cells, each step to a
/// neighbour, with no cell twice.
pub fn is_valid(grid: &PlanningGrid, path: &[Cell], start: Cell, goal: Cell) -> bool {
    path.first() == Some(&start)
        && path.last() == Some(&goal)
        && path.iter().all(|&c| grid.is_free(c))
        && repeat_free(path)
        && path.windows(2).all(|w| grid.adjacent(w[0], w[1]))
}

/// Layered selection (4.3.1): indices into a population sorted best first (ascending fitness).
/// The first `N / 3` are taken twice, the next `N / 3` once, and the rest of the `N` places go to
/// the best of the remaining layer.
pub fn layered_selection(n: usize) -> Vec<usize> {
    let third = n / 3;
    let mut out = Vec::with_capacity(n);
    for i in 0..third {
        out.push(i);
        out.push(i);
    }
    out.extend(third..2 * third);
    let mut k = 2 * third;
    while out.len() < n {
        out.push(k);
        k += 1;
    }
    out
}

/// Cuts every loop (a cell met twice keeps only its first visit) so a spliced path stays
/// repeat-free; the path stays continuous because the cell after the cut follows the repeat.
pub fn remove_loops(path: &mut Vec<Cell>) {
    let mut out: Vec<Cell> = Vec::with_capacity(path.len());
    let mut pos = FxHashMap::with_capacity_and_hasher(path.len(), Default::default());
    for &c in path.iter() {
        if let Some(&i) = pos.get(&c) {
            for removed in out.drain(i + 1..) {
                pos.remove(&removed);
            }
        } else {
            pos.insert(c, out.len());
            out.push(c);
        }
    }
    *path = out;
}

/// Fills every gap of a gene sequence (4.1): median insertion for IMGA, random insertion for
/// the plain GA. `None` when the individual cannot be completed.
pub fn connect(
    grid: &PlanningGrid,
    mut path: Vec<Cell>,
    median: bool,
    budget: usize,
    rng: &mut impl Rng,
) -> Option<Vec<Cell>> {
    // Random gap filling makes far longer paths than the median: give it room.
    let budget = if median { budget } else { budget * 4 };
    let mut on_path: FxHashSet<Cell> = path.iter().copied().collect();
    let mut insertions = 0;
    let mut i = 0;
    while i + 1 < path.len() {
        let (a, b) = (path[i], path[i + 1]);
        if grid.adjacent(a, b) {
            i += 1;
            continue;
        }
        insertions += 1;
        if insertions > budget {
            return None;
        }
        // Neighbours by distance but not by move rule (a blocked corner): go round by a free side.
        if (b.x - a.x).abs() <= 1 && (b.y - a.y).abs() <= 1 {
            let side = [a.offset(b.x - a.x, 0), a.offset(0, b.y - a.y)]
                .into_iter()
                .find(|&s| grid.is_free(s) && !on_path.contains(&s))?;
            path.insert(i + 1, side);
            on_path.insert(side);
            continue;
        }
        let target = if median {
            // Eq. 3: the median cell of the two genes.
            Cell::new((a.x + b.x).div_euclid(2), (a.y + b.y).div_euclid(2))
        } else {
            Cell::new(
                rng.random_range(a.x.min(b.x)..=a.x.max(b.x)),
                rng.random_range(a.y.min(b.y)..=a.y.max(b.y)),
            )
        };
        // Only cells strictly closer (Chebyshev) to both genes than they are to each other: every
        // insertion shrinks its gaps, so filling always ends.
        let cheb = |p: Cell, q: Cell| (p.x - q.x).abs().max((p.y - q.y).abs());
        let gap = cheb(a, b);
        let ok = |c: Cell| {
            grid.is_free(c) && !on_path.contains(&c) && cheb(a, c) < gap && cheb(c, b) < gap
        };
        let chosen = if ok(target) {
            target
        } else {
            // The paper's random free 8-neighbour, then (inflated obstacles are thick) the next
            // rings out, up to the gap's own size.
            let reach = (b.x - a.x).abs().max((b.y - a.y).abs()).max(1);
            // Every `ok` cell is in this rectangle: within gap - 1 of both genes on each axis.
            let closer = (
                a.x.max(b.x) - (gap - 1),
                a.y.max(b.y) - (gap - 1),
                a.x.min(b.x) + (gap - 1),
                a.y.min(b.y) + (gap - 1),
            );
            (1..=reach).find_map(|r| {
                let ring: Vec<Cell> = ring_may_hold(grid, target, r, closer)
                    .into_iter()
                    .filter(|&c| ok(c))
                    .collect();
                ring.get(rng.random_range(0..ring.len().max(1))).copied()
            })?
        };
        path.insert(i + 1, chosen);
        on_path.insert(chosen);
    }
    remove_loops(&mut path);
    Some(path)
}

/// The cells of [`ring`] (`centre`, `r`) that may be free and lie in the rectangle `within`
/// (`x0, y0, x1, y1`, inclusive), in the ring's order. A stretch of the ring with no free cell
/// ([`PlanningGrid::none_free`], four reads) is passed over whole. A median cell inside a
/// warehouse shelf grows rings as wide as the gap, nearly all inside the shelf or too far from
/// the genes, and walking them cell by cell was 65 % of imga's time on the Nav2 warehouse map
/// (the initial population's attempts, most of which fail there).
fn ring_may_hold(
    grid: &PlanningGrid,
    centre: Cell,
    r: i32,
    (x0, y0, x1, y1): (i32, i32, i32, i32),
) -> Vec<Cell> {
    let (cx, cy) = (centre.x, centre.y);
    let mut bottom = Vec::new();
    may_hold(
        grid,
        (cx - r, cy - r),
        (cx + r, cy - r),
        (x0, y0, x1, y1),
        &mut bottom,
    );
    if r == 0 {
        return bottom;
    }
    // The rows between: the left column's cells then the right's, put in row order by a stable
    // sort, which keeps a row's left cell before its right one.
    let mut between = Vec::new();
    let (lo, hi) = (cy - r + 1, cy + r - 1);
    for x in [cx - r, cx + r] {
        may_hold(grid, (x, lo), (x, hi), (x0, y0, x1, y1), &mut between);
    }
    between.sort_by_key(|c| c.y);
    let mut out = bottom;
    out.append(&mut between);
    may_hold(
        grid,
        (cx - r, cy + r),
        (cx + r, cy + r),
        (x0, y0, x1, y1),
        &mut out,
    );
    out
}

/// Appends the cells of the straight stretch `from ..= to` (a row or a column, ascending)
/// inside `within` that may be free: halves with no free cell are passed over.
fn may_hold(
    grid: &PlanningGrid,
    from: (i32, i32),
    to: (i32, i32),
    (x0, y0, x1, y1): (i32, i32, i32, i32),
    out: &mut Vec<Cell>,
) {
    let (xa, ya, xb, yb) = (from.0.max(x0), from.1.max(y0), to.0.min(x1), to.1.min(y1));
    if xa > xb || ya > yb || grid.none_free(xa, ya, xb, yb) {
        return;
    }
    let cells = (xb - xa).max(yb - ya) + 1;
    if cells <= 8 {
        out.extend((ya..=yb).flat_map(|y| (xa..=xb).map(move |x| Cell::new(x, y))));
        return;
    }
    let half = cells / 2;
    let ((ma, mb), (na, nb)) = if xb > xa {
        ((xa + half - 1, ya), (xa + half, ya))
    } else {
        ((xa, ya + half - 1), (xa, ya + half))
    };
    may_hold(grid, (xa, ya), (ma, mb), (x0, y0, x1, y1), out);
    may_hold(grid, (na, nb), (xb, yb), (x0, y0, x1, y1), out);
}

/// The cells at Chebyshev distance `r` from `centre`, row by row (dy, then dx, ascending): the
/// ring search's order, which [`ring_may_hold`] keeps (this walk of every cell is its reference
/// in the tests).
#[cfg(test)]
fn ring(centre: Cell, r: i32) -> impl Iterator<Item = Cell> {
    (-r..=r).flat_map(move |dy| {
        let (step, dx0) = if dy.abs() == r { (1, -r) } else { (2 * r, -r) };
        (0..)
            .map(move |k| dx0 + k * step)
            .take_while(move |&dx| dx <= r)
            .map(move |dx| centre.offset(dx, dy))
    })
}

/// Single-point crossover (4.3.2) at a random cell both parents share (not the start or goal).
/// Returns whether it happened; children have their loops cut.
pub fn crossover(a: &mut Vec<Cell>, b: &mut Vec<Cell>, rng: &mut impl Rng) -> bool {
    let inner_b: FxHashMap<Cell, usize> = b
        .iter()
        .enumerate()
        .take(b.len().saturating_sub(1))
        .skip(1)
        .map(|(i, &c)| (c, i))
        .collect();
    let shared: Vec<(usize, usize)> = a
        .iter()
        .enumerate()
        .take(a.len().saturating_sub(1))
        .skip(1)
        .filter_map(|(i, c)| inner_b.get(c).map(|&j| (i, j)))
        .collect();
    let Some(&(i, j)) = shared.get(rng.random_range(0..shared.len().max(1))) else {
        return false;
    };
    // Parents are chromosomes, each cell once, so a child can repeat only a cell both parents
    // hold on either side of the cut: one `a` holds before `i` and `b` after `j` (the first
    // child, `a[..i] + b[j..]`), or one `a` holds after `i` and `b` before `j` (the second). Where
    // there is none, cutting loops would walk the whole child to change nothing: children of
    // one seed mostly cross their shared cells in the same order.
    debug_assert!(
        repeat_free(a) && repeat_free(b),
        "parents hold each cell once"
    );
    let loops_in_a = shared.iter().any(|&(ia, jb)| ia < i && jb > j);
    let loops_in_b = shared.iter().any(|&(ia, jb)| ia > i && jb < j);
    let tail_a = a.split_off(i);
    let tail_b = b.split_off(j);
    a.extend(tail_b);
    b.extend(tail_a);
    if loops_in_a {
        remove_loops(a);
    }
    if loops_in_b {
        remove_loops(b);
    }
    true
}

/// Whether every cell of `path` is there once.
fn repeat_free(path: &[Cell]) -> bool {
    let mut seen = FxHashSet::default();
    path.iter().all(|&c| seen.insert(c))
}

/// Eight-neighbourhood single-point mutation (4.3.3): a random inner gene moves to a random free
/// 8-neighbour not already on the path, and the path is reconnected by insertion. `None` when no
/// neighbour is free or the reconnection fails (the mutation is skipped).
pub fn mutate(
    grid: &PlanningGrid,
    path: &[Cell],
    median: bool,
    budget: usize,
    rng: &mut impl Rng,
) -> Option<Vec<Cell>> {
    if path.len() < 3 {
        return None;
    }
    let i = rng.random_range(1..path.len() - 1);
    let options: Vec<Cell> = NEIGHBOURS_8
        .iter()
        .map(|&(dx, dy)| path[i].offset(dx, dy))
        .filter(|&c| grid.is_free(c) && !path.contains(&c))
        .collect();
    let &m = options.get(rng.random_range(0..options.len().max(1)))?;
    let mut genes = path.to_vec();
    genes[i] = m;
    connect(grid, genes, median, budget, rng)
}

/// IMGA's mutation at scale ([`super::GaMutation::Reroute`]): the stretch between cells `i` and `j` of
/// the path (`j - i` log-uniform in 2 ..= the path's last index) is replaced by median insertion
/// from `path[i]` through a random free cell within a quarter of the stretch's span (Chebyshev)
/// of its middle to `path[j]`. `None` when no such cell is found in a few draws or the
/// reconnection fails (the mutation is skipped).
pub fn reroute(
    grid: &PlanningGrid,
    path: &[Cell],
    budget: usize,
    rng: &mut impl Rng,
) -> Option<Vec<Cell>> {
    let last = path.len().checked_sub(1)?;
    if last < 2 {
        return None;
    }
    // Log-uniform: as many short corner cuts as long detours.
    let stretch = ((2.0f64).ln() + rng.random::<f64>() * ((last as f64).ln() - (2.0f64).ln()))
        .exp()
        .round()
        .clamp(2.0, last as f64) as usize;
    let i = rng.random_range(0..=last - stretch);
    let j = i + stretch;
    let (a, b) = (path[i], path[j]);
    let reach = ((a.x - b.x).abs().max((a.y - b.y).abs()) / 4).max(1);
    let middle = Cell::new((a.x + b.x).div_euclid(2), (a.y + b.y).div_euclid(2));
    let via = (0..8).find_map(|_| {
        let c = middle.offset(
            rng.random_range(-reach..=reach),
            rng.random_range(-reach..=reach),
        );
        (grid.is_free(c) && c != a && c != b).then_some(c)
    })?;
    let mut genes = Vec::with_capacity(path.len() - stretch + 2);
    genes.extend_from_slice(&path[..=i]);
    // A `via` on the kept part of the path would splice in a loop: the stretch is then
    // reconnected directly instead.
    if !genes.contains(&via) && !path[j..].contains(&via) {
        genes.push(via);
    }
    genes.extend_from_slice(&path[j..]);
    connect(grid, genes, true, budget, rng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{grid_from_rows, random_grid, rng};
    use proptest::prelude::{any, prop_assert, prop_assert_eq, proptest, ProptestConfig};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Median insertion always yields continuous, repeat-free, obstacle-free paths (or
        /// discards the individual).
        #[test]
        fn median_insertion_yields_valid_paths(seed in any::<u64>(), density in 0.0f64..0.3) {
            let (grid, s, g) = random_grid(seed, 20, 15, density);
            let mut r = rng(seed);
            for _ in 0..10 {
                let mid = Cell::new(r.random_range(0..20), r.random_range(0..15));
                if !grid.is_free(mid) || mid == s || mid == g { continue; }
                if let Some(path) = connect(&grid, vec![s, mid, g], true, 200, &mut r) {
                    prop_assert!(is_valid(&grid, &path, s, g), "{:?}", path);
                }
            }
        }

        /// Crossover happens only at shared cells and its children stay valid; mutation keeps
        /// validity or reports failure.
        #[test]
        fn crossover_and_mutation_keep_paths_valid(seed in any::<u64>(), density in 0.0f64..0.25) {
            let (grid, s, g) = random_grid(seed, 16, 12, density);
            let mut r = rng(seed);
            let mut parents = Vec::new();
            for _ in 0..20 {
                let mid = Cell::new(r.random_range(0..16), r.random_range(0..12));
                if grid.is_free(mid) && mid != s && mid != g {
                    if let Some(p) = connect(&grid, vec![s, mid, g], true, 200, &mut r) { parents.push(p); }
                }
            }
            for pair in parents.chunks_exact(2) {
                let (mut a, mut b) = (pair[0].clone(), pair[1].clone());
                let shared = pair[0][1..pair[0].len() - 1].iter().any(|c| pair[1][1..pair[1].len() - 1].contains(c));
                let crossed = crossover(&mut a, &mut b, &mut r);
                prop_assert_eq!(crossed, shared);
                // Repeat-free (checked by `is_valid` below) is what cutting loops makes of a child,
                // and a repeat-free path is its own loops cut: a skipped cut changed nothing.
                let (mut cut_a, mut cut_b) = (a.clone(), b.clone());
                remove_loops(&mut cut_a);
                remove_loops(&mut cut_b);
                prop_assert_eq!((&cut_a, &cut_b), (&a, &b));
                if !crossed { prop_assert_eq!(&a, &pair[0]); }
                prop_assert!(is_valid(&grid, &a, s, g) && is_valid(&grid, &b, s, g));
                if let Some(m) = mutate(&grid, &a, true, 200, &mut r) {
                    prop_assert!(is_valid(&grid, &m, s, g));
                }
                if let Some(m) = reroute(&grid, &a, 200, &mut r) {
                    prop_assert!(is_valid(&grid, &m, s, g));
                }
            }
        }
    }

    /// In open space nearly every reroute of a straight staircase succeeds, and each is a
    /// continuous, repeat-free, obstacle-free path between the same ends (the property test
    /// above checks validity only when one comes back).
    #[test]
    fn reroutes_mostly_succeed_in_open_space() {
        let grid = grid_from_rows(&["...................."; 20]);
        let (s, g) = (Cell::new(0, 10), Cell::new(19, 10));
        let path: Vec<Cell> = (0..20).map(|x| Cell::new(x, 10)).collect();
        let mut r = rng(3);
        let mut ok = 0;
        for _ in 0..50 {
            if let Some(m) = reroute(&grid, &path, 200, &mut r) {
                assert!(is_valid(&grid, &m, s, g));
                ok += 1;
            }
        }
        assert!(ok >= 45, "{ok} of 50");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        /// The ring search's candidates are the ring's cells, in the ring's order, less only
        /// cells that are not free or lie outside the rectangle: on random maps (mostly blocked,
        /// like a shelf, or open), centres near and off the edges, rectangles of any size.
        #[test]
        fn ring_may_hold_drops_only_blocked_and_outside_cells(
            seed in any::<u64>(),
            density in 0.0f64..1.0,
            cx in -4i32..44,
            cy in -4i32..34,
            r in 0i32..30,
            x0 in -10i32..40,
            y0 in -10i32..30,
            w in 0i32..50,
            h in 0i32..40,
        ) {
            let (grid, _, _) = random_grid(seed, 40, 30, density);
            let within = (x0, y0, x0 + w, y0 + h);
            let inside = |c: &Cell| c.x >= within.0 && c.y >= within.1 && c.x <= within.2 && c.y <= within.3;
            let expected: Vec<Cell> = ring(Cell::new(cx, cy), r)
                .filter(|c| grid.is_free(*c) && inside(c))
                .collect();
            let got: Vec<Cell> = ring_may_hold(&grid, Cell::new(cx, cy), r, within)
                .into_iter()
                .filter(|c| grid.is_free(*c))
                .collect();
            prop_assert_eq!(got, expected);
        }
    }

    /// The ring is the square's border in row order, as a filter over the whole square gives it.
    #[test]
    fn ring_is_the_squares_border_in_row_order() {
        let c = Cell::new(3, -2);
        for r in 1i32..6 {
            let by_filter: Vec<Cell> = (-r..=r)
                .flat_map(|dy| (-r..=r).map(move |dx| (dx, dy)))
                .filter(|&(dx, dy)| dx.abs() == r || dy.abs() == r)
                .map(|(dx, dy)| c.offset(dx, dy))
                .collect();
            assert_eq!(ring(c, r).collect::<Vec<_>>(), by_filter, "r = {r}");
        }
    }

    #[test]
    fn layered_selection_copy_counts_for_9_and_10() {
        let count = |sel: &[usize], i: usize| sel.iter().filter(|&&k| k == i).count();
        let nine = layered_selection(9);
        assert_eq!(nine.len(), 9);
        assert!((0..3).all(|i| count(&nine, i) == 2));
        assert!((3..6).all(|i| count(&nine, i) == 1));
        assert!((6..9).all(|i| count(&nine, i) == 0));
        let ten = layered_selection(10);
        assert_eq!(ten.len(), 10);
        assert!((0..3).all(|i| count(&ten, i) == 2));
        assert!((3..6).all(|i| count(&ten, i) == 1));
        // The last place goes to the best of the third layer (index 6), none to the rest.
        assert_eq!(count(&ten, 6), 1);
        assert!((7..10).all(|i| count(&ten, i) == 0));
    }
}
