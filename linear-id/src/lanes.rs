//! What the lane-parallel recursions share (`recursive/lanes.rs`, `parsim/lanes.rs`): several
//! grid nodes advance through one serial recursion together, one per SIMD lane, each lane
//! performing the single recursion's operations in the same order (so the same bits).

/// Nodes run side by side (four doubles: one AVX register, two SSE2 registers).
pub(crate) const LANES: usize = 4;

/// One scalar of the recursion, per lane.
pub(crate) type Lanes = [f64; LANES];

/// `f(l)` for every lane.
#[inline(always)]
pub(crate) fn each(mut f: impl FnMut(usize) -> f64) -> Lanes {
    let mut out = [0.0; LANES];
    for (l, v) in out.iter_mut().enumerate() {
        *v = f(l);
    }
    out
}

thread_local! {
    /// Buffers of [`Scratch`], reused: a record's worth of lanes is about 100 kB, and a fresh
    /// allocation of that size per batch of nodes costs page faults and zeroing.
    static POOL: std::cell::RefCell<Vec<Vec<Lanes>>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Zeroed lanes from a thread-local pool, returned to it on drop (several may be live).
pub(crate) struct Scratch(Vec<Lanes>);

impl Scratch {
    /// `len` zeroed lanes.
    pub(crate) fn zeroed(len: usize) -> Scratch {
        let mut buf = POOL.with(|p| p.borrow_mut().pop()).unwrap_or_default();
        buf.clear();
        buf.resize(len, [0.0; LANES]);
        Scratch(buf)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let buf = std::mem::take(&mut self.0);
        POOL.with(|p| p.borrow_mut().push(buf));
    }
}

impl std::ops::Deref for Scratch {
    type Target = [Lanes];
    fn deref(&self) -> &[Lanes] {
        &self.0
    }
}

impl std::ops::DerefMut for Scratch {
    fn deref_mut(&mut self) -> &mut [Lanes] {
        &mut self.0
    }
}
