//! The few nearest of a stream of candidates within a radius ([`NearestFew`]): an unordered,
//! fixed-capacity list that tracks its farthest entry, the answer of a
//! [`super::NearTree`] query.

/// Most neighbours a query keeps.
pub const MAX_NEAREST: usize = 64;

/// The nearest few of a stream of candidates, in no particular order: until it is full a
/// candidate is appended; then one nearer than the farthest kept replaces it, and the
/// farthest is found again. A list kept sorted by insertion spent most of a search shifting
/// entries on branches the processor could not predict. It also holds a search's pending
/// cells, so that a query allocates nothing.
#[derive(Clone, Debug)]
pub struct NearestFew {
    capacity: usize,
    len: usize,
    distance2: [f32; MAX_NEAREST],
    id: [u32; MAX_NEAREST],
    /// The farthest kept, and where, once the list is full.
    farthest: (f32, usize),
    pub(super) pending: Vec<Pending>,
}

/// A far child left for later: its node, the squared distance from the query to its cell and
/// that distance's components along each axis (Arya and Mount's incremental distance).
#[derive(Clone, Copy, Debug)]
pub(super) struct Pending {
    pub(super) node: u32,
    pub(super) floor: f32,
    pub(super) offset: [f32; 3],
}

impl NearestFew {
    /// At most `capacity` (clamped to `1..=MAX_NEAREST`).
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.clamp(1, MAX_NEAREST),
            len: 0,
            distance2: [0.0; MAX_NEAREST],
            id: [0; MAX_NEAREST],
            farthest: (0.0, 0),
            pending: Vec::with_capacity(64),
        }
    }

    pub fn clear(&mut self) {
        self.len = 0;
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn is_full(&self) -> bool {
        self.len == self.capacity
    }

    /// The squared distance a candidate must be below to be kept, given the radius `r2`.
    #[inline]
    pub(super) fn bound(&self, r2: f32) -> f32 {
        if self.len == self.capacity {
            self.farthest.0
        } else {
            r2
        }
    }

    /// Keeps `id` if it is among the nearest so far.
    #[inline]
    pub fn offer(&mut self, d2: f32, id: u32) {
        if self.len < self.capacity {
            self.distance2[self.len] = d2;
            self.id[self.len] = id;
            self.len += 1;
            if self.len == self.capacity {
                self.find_farthest();
            }
        } else if d2 < self.farthest.0 {
            let at = self.farthest.1;
            self.distance2[at] = d2;
            self.id[at] = id;
            self.find_farthest();
        }
    }

    #[inline]
    fn find_farthest(&mut self) {
        let mut farthest = (self.distance2[0], 0);
        for (i, &d) in self.distance2[..self.len].iter().enumerate().skip(1) {
            if d > farthest.0 {
                farthest = (d, i);
            }
        }
        self.farthest = farthest;
    }

    /// The largest squared distance kept (0 when empty).
    pub fn farthest_distance2(&self) -> f32 {
        if self.is_full() {
            // Tracked since the list filled.
            self.farthest.0
        } else {
            self.distance2[..self.len]
                .iter()
                .copied()
                .fold(0.0, f32::max)
        }
    }

    /// The ids kept, in no particular order.
    pub fn ids(&self) -> &[u32] {
        &self.id[..self.len]
    }

    /// The squared distances kept, in the order of [`NearestFew::ids`].
    pub fn distances2(&self) -> &[f32] {
        &self.distance2[..self.len]
    }
}
