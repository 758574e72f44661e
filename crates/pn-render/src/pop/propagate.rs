//! The light-aligned propagation grid and the six-neighbour gathering propagation
//! (POP paper §4.2–4.3, Eqs. 2 and 4–6) with double buffering and per-iteration energy
//! bookkeeping.
//!
//! **Grid.** [`LightGrid`] is a uniform grid of cubic cells of side `h` whose third axis is
//! the light's travel direction `d` (cells are indexed `(i, j, k)`, k along d; storage
//! `(k·ny + j)·nx + i`, so that a plane k ⟂ d is one contiguous slice: the unit of rayon
//! parallelism). It covers the given box (the medium's support) in the frame (u, v, d).
//!
//! **Other grids.** The iteration itself ([`propagate_on`]) needs only each cell's six
//! neighbours and which of its patches points at each ([`Stencil`]) and per cell and
//! patch the halves of the two factors below ([`HalfSteps`]): a point light's radial grid
//! ([`super::radial`]) is the second implementation, with its own half-steps per patch
//! ([`Halves`]).
//!
//! **One iteration** (Eq. 5–6, gathering): every destination cell sums what its six
//! neighbours send it, `ΔL = L_src · frac · T_src→dst` with `frac` the source's patch
//! fraction towards dst ([`super::hg_patch::Patches`]), and takes the ΔL-weighted mean of
//! the reduced anisotropies `Δa = a_src · g^{σ_s t}` (Eq. 4). Following the paper,
//! `T = exp(−σ̄_a t)` and the exponent of Eq. 4 use the mean of the two cells' σ_a and σ_s
//! and the centre distance `t = h`; both factor into per-cell halves,
//! `exp(−σ_a,src h/2)·exp(−σ_a,dst h/2)` and `g^{σ_s,src h/2}·g^{σ_s,dst h/2}`, computed once.
//! Outside the grid is vacuum (σ = 0): what a face cell sends outwards has crossed half a
//! cell of medium and is counted as having **left the grid**. All energy of a cell moves
//! each iteration (one step of length h per iteration), so the grid `L^m` holds the light
//! that is still in flight.
//!
//! **Bookkeeping.** Energy is reported as power, `Σ L · h²` (the initial `L_i^0 = σ_s E T h`
//! of [`super`] makes `Σ L^0 h²` the once-scattered power `Σ σ_s E T h³`). Since the patches
//! sum to one, `in flight(m+1) + left grid(m) + absorbed(m) = in flight(m)` holds to
//! rounding in every iteration ([`IterationEnergy`]).
//!
//! **Isotropic residuum** (§5.4, [`Schedule::Residuum`]): after m′ iterations the lobes'
//! anisotropies are set to 0 (magnitudes kept, so the bookkeeping is unchanged) and the
//! iteration goes on with the fixed isotropic patches (Eq. 3 at a = 0, computed once) until
//! the power in flight falls below ε_L times the injected power. With one grid per light the
//! paper's merging of all lights' grids into one medium-aligned grid is not done: each light
//! finishes isotropically in its own grid (the same transport, without the resampling error
//! of a merge; docs/pop-design.md).
//!
//! **Accumulation** (Eq. 7–8 for every view direction at once): instead of the
//! view-dependent scalar of Eq. 8, each cell accumulates the band amplitudes
//! `A_l = Σ_m w_m L^m (a^m)^l`, l = 0..=lmax ([`super::accumulate`] turns them into SH
//! moments), with `w_0 = ½` for the cell's own once-scattered light (on average a point of
//! the cell has seen half of its own cell's emission; docs/pop-design.md) and `w_m = 1`
//! for m ≥ 1.

use super::hg_patch::Patches;
use anyhow::ensure;
use rayon::prelude::*;
use serde::Serialize;

/// A uniform grid of cubic cells aligned with a light's travel direction.
#[derive(Clone, Debug, PartialEq)]
pub struct LightGrid {
    /// World position of the grid's lower corner (cell (0, 0, 0)'s corner).
    pub origin: [f64; 3],
    /// Orthonormal axes (u, v, d): `axes[2]` is the light's travel direction.
    pub axes: [[f64; 3]; 3],
    /// Cells along u, v, d.
    pub res: [usize; 3],
    /// Cell side.
    pub h: f64,
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalized(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    a.map(|c| c / n)
}

/// An orthonormal frame (u, v, d) with d = `direction` normalised (non-zero, finite): u ⟂ d
/// from the world axis least aligned with d, v = d × u.
pub fn frame(direction: [f64; 3]) -> [[f64; 3]; 3] {
    let d = normalized(direction);
    let a = (0..3)
        .min_by(|&x, &y| d[x].abs().total_cmp(&d[y].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[a] = 1.0;
    let u = normalized(cross(d, e));
    let v = cross(d, u);
    [u, v, d]
}

impl LightGrid {
    /// The grid with third axis `direction` that covers the box `[lo, hi]`: its extent in
    /// the frame (u, v, d) is the box's (its eight corners projected), the cell side is the
    /// longest extent over `resolution`, and each axis gets enough cells to cover its extent
    /// (centred on it).
    pub fn around_box(
        direction: [f64; 3],
        lo: [f64; 3],
        hi: [f64; 3],
        resolution: usize,
    ) -> anyhow::Result<LightGrid> {
        let n2 = dot(direction, direction);
        ensure!(
            n2.is_finite() && n2 > 0.0,
            "light direction {direction:?} is not a finite non-zero vector"
        );
        ensure!(
            (0..3).all(|d| lo[d].is_finite() && hi[d].is_finite() && lo[d] <= hi[d]),
            "POP: the box {lo:?} to {hi:?} is not a finite box"
        );
        ensure!(resolution > 0, "POP: the grid resolution must be positive");
        let axes = frame(direction);
        let mut pmin = [f64::INFINITY; 3];
        let mut pmax = [f64::NEG_INFINITY; 3];
        for c in 0..8 {
            let p = [0, 1, 2].map(|q| if c >> q & 1 == 1 { hi[q] } else { lo[q] });
            for (ax, axis) in axes.iter().enumerate() {
                let s = dot(p, *axis);
                pmin[ax] = pmin[ax].min(s);
                pmax[ax] = pmax[ax].max(s);
            }
        }
        let ext = [0, 1, 2].map(|ax| pmax[ax] - pmin[ax]);
        let longest = ext.iter().fold(0.0f64, |m, v| m.max(*v));
        ensure!(longest > 0.0, "POP: the box {lo:?} to {hi:?} is empty");
        let h = longest / resolution as f64;
        let res = ext.map(|e| ((e / h - 1e-9).ceil() as usize).clamp(1, resolution));
        // Centre each axis's cells on the box's extent.
        let start = [0, 1, 2].map(|ax| 0.5 * (pmin[ax] + pmax[ax]) - 0.5 * res[ax] as f64 * h);
        let origin = [0, 1, 2].map(|q| (0..3).map(|ax| start[ax] * axes[ax][q]).sum::<f64>());
        Ok(LightGrid {
            origin,
            axes,
            res,
            h,
        })
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.res.iter().product()
    }

    /// Storage index of cell (i, j, k): `(k·ny + j)·nx + i` (a plane k is contiguous).
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.res[1] + j) * self.res[0] + i
    }

    /// World position of the centre of cell `c`.
    pub fn centre(&self, c: [usize; 3]) -> [f64; 3] {
        let s = c.map(|v| (v as f64 + 0.5) * self.h);
        [0, 1, 2].map(|q| self.origin[q] + (0..3).map(|ax| s[ax] * self.axes[ax][q]).sum::<f64>())
    }

    /// Continuous cell coordinates of the world point `x`: cell c's centre is at `c`.
    pub fn local(&self, x: [f64; 3]) -> [f64; 3] {
        let r = [0, 1, 2].map(|q| x[q] - self.origin[q]);
        [0, 1, 2].map(|ax| dot(r, self.axes[ax]) / self.h - 0.5)
    }
}

/// The medium on a [`LightGrid`] (per cell, in its storage order).
#[derive(Clone, Debug, PartialEq)]
pub struct PopMedium {
    /// Scattering coefficient σ_s.
    pub sigma_s: Vec<f64>,
    /// Absorption coefficient σ_a = σ_t − σ_s.
    pub sigma_a: Vec<f64>,
    /// Henyey–Greenstein g of the phase function, in [0, 1).
    pub g: f64,
}

/// The energy balance of one iteration (powers, `Σ L h²`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct IterationEnergy {
    /// Iteration m (1-based: the step from `L^{m−1}` to `L^m`).
    pub iteration: usize,
    /// In flight before the step (`Σ L^{m−1} h²`).
    pub in_flight_before: f64,
    /// Sent out of the grid's faces in this step.
    pub left_grid: f64,
    /// Absorbed on the way between cell centres in this step.
    pub absorbed: f64,
    /// In flight after the step (`Σ L^m h²`).
    pub in_flight_after: f64,
}

impl IterationEnergy {
    /// `in flight before − (in flight after + left + absorbed)`: rounding only.
    pub fn imbalance(&self) -> f64 {
        self.in_flight_before - (self.in_flight_after + self.left_grid + self.absorbed)
    }
}

/// How many iterations to run ([`propagate_scheduled`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Schedule {
    /// A fixed number of iterations, with lobes throughout (the paper's §4).
    Fixed(usize),
    /// The isotropic residuum (§5.4): `anisotropic` iterations with lobes, then every lobe is
    /// made isotropic (a = 0; the magnitudes, hence the energy, are kept) and the iteration
    /// goes on without anisotropies until the power in flight is at most `epsilon_l` times
    /// the injected power, or `max_total` iterations in all have run.
    Residuum {
        /// Iterations with lobes before the switch (m′ of Eq. 10).
        anisotropic: usize,
        /// Stop when `in flight ≤ epsilon_l · injected`.
        epsilon_l: f64,
        /// At most this many iterations in all.
        max_total: usize,
    },
}

/// What the isotropic residuum did ([`Schedule::Residuum`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ResiduumInfo {
    /// The iteration after which the lobes were made isotropic.
    pub switch_iteration: usize,
    /// The energy-weighted mean anisotropy `Σ L a / Σ L` of the lobes at the switch.
    pub mean_anisotropy_at_switch: f64,
    /// The largest anisotropy at the switch among cells holding at least 1e−3 of the
    /// largest magnitude.
    pub max_anisotropy_at_switch: f64,
    /// Fraction of the injected power in flight at the switch.
    pub in_flight_fraction_at_switch: f64,
    /// Isotropic iterations after the switch.
    pub isotropic_iterations: usize,
    /// Whether the power in flight fell to `epsilon_l` of the injected power (false: the
    /// iteration cap was reached first).
    pub reached_epsilon_l: bool,
}

/// The result of [`propagate`].
#[derive(Clone, Debug, PartialEq)]
pub struct Propagated {
    /// Band amplitudes `A_l` per cell: `bands[c·(lmax+1) + l]` (c the storage index).
    pub bands: Vec<f64>,
    /// Highest band accumulated.
    pub lmax: usize,
    /// Power injected (`Σ L^0 h²`).
    pub injected: f64,
    /// One entry per iteration.
    pub energy: Vec<IterationEnergy>,
    /// `L^M`: what is still in flight after the last iteration (per cell).
    pub residual: Vec<f64>,
    /// The anisotropy `a^M` of the residual (per cell).
    pub residual_anisotropy: Vec<f64>,
    /// What the isotropic residuum did (None for [`Schedule::Fixed`]).
    pub residuum: Option<ResiduumInfo>,
}

/// Propagates the initial lobes `L^0 = source`, `a^0 = g` (the once-scattered light of
/// [`super`]) through `iterations` steps on `grid` (module docs) and accumulates the band
/// amplitudes up to `lmax`.
pub fn propagate(
    grid: &LightGrid,
    medium: &PopMedium,
    source: &[f64],
    lmax: usize,
    iterations: usize,
) -> anyhow::Result<Propagated> {
    propagate_from(grid, medium, source, medium.g, lmax, iterations)
}

/// [`propagate`] from lobes of anisotropy `initial_anisotropy` ∈ [0, 1] instead of g: 1 is
/// the paper's §4.1 initialisation with the attenuated (uncollided) light, kept for the
/// measurement of open point 3 (docs/pop-design.md).
pub fn propagate_from(
    grid: &LightGrid,
    medium: &PopMedium,
    source: &[f64],
    initial_anisotropy: f64,
    lmax: usize,
    iterations: usize,
) -> anyhow::Result<Propagated> {
    let schedule = Schedule::Fixed(iterations);
    propagate_scheduled(grid, medium, source, initial_anisotropy, lmax, schedule)
}

/// [`propagate_from`] with the iteration count given by `schedule`: a fixed count, or the
/// isotropic residuum of §5.4 ([`Schedule::Residuum`]).
pub fn propagate_scheduled(
    grid: &LightGrid,
    medium: &PopMedium,
    source: &[f64],
    initial_anisotropy: f64,
    lmax: usize,
    schedule: Schedule,
) -> anyhow::Result<Propagated> {
    check_inputs(grid.cells(), medium, source, initial_anisotropy, schedule)?;
    let h = grid.h;
    let g = medium.g;
    // Per-cell halves of Eq. 2's transmittance and Eq. 4's factor (module docs): the same
    // half length h/2 towards every neighbour.
    let t: Vec<f64> = medium
        .sigma_a
        .iter()
        .map(|s| (-0.5 * s * h).exp())
        .collect();
    let gh: Vec<f64> = medium.sigma_s.iter().map(|s| g.powf(0.5 * s * h)).collect();
    let halves = UniformHalves { t, g: gh };
    propagate_on(
        grid,
        &halves,
        h * h,
        source,
        initial_anisotropy,
        lmax,
        schedule,
    )
}

/// The neighbourhood of a propagation grid: cells (i, j, k) stored at `(k·ny + j)·nx + i`,
/// a plane k of `nx × ny` contiguous cells being the unit of parallelism, each cell with six
/// neighbours that its lobe's front, side or back patch points at. The light-aligned
/// [`LightGrid`] and the radial grid of a point light ([`super::radial::RadialGrid`]) are
/// the two implementations.
pub trait Stencil: Sync {
    /// Cells along the three axes (nx, ny: a plane; nz planes).
    fn shape(&self) -> [usize; 3];
    /// Number of cells.
    fn cells(&self) -> usize {
        self.shape().iter().product()
    }
    /// The six neighbours of cell (i, j, k) as (storage index, or None where the patch leaves
    /// the grid; which patch of the cell points at it: [`FRONT`], [`SIDE`] or [`BACK`];
    /// which patch of the neighbour points back at the cell), in the order front, back, then
    /// the four sides. The relation must be symmetric (n lists c with the two patches swapped
    /// whenever c lists n), so that what is sent is what is gathered.
    fn neighbours(&self, i: usize, j: usize, k: usize) -> [Neighbour; 6];
}

/// One neighbour of a cell ([`Stencil::neighbours`]): its storage index (None: outside the
/// grid), the cell's patch that points at it, and its patch that points back.
pub type Neighbour = (Option<usize>, u8, u8);

/// The patch towards the neighbour in front (along the principal direction).
pub const FRONT: u8 = 0;
/// A patch towards one of the four side neighbours.
pub const SIDE: u8 = 1;
/// The patch towards the neighbour behind.
pub const BACK: u8 = 2;

impl Stencil for LightGrid {
    fn shape(&self) -> [usize; 3] {
        self.res
    }

    #[inline(always)]
    fn neighbours(&self, i: usize, j: usize, k: usize) -> [Neighbour; 6] {
        let [nx, ny, nz] = self.res;
        let at = |ok: bool, ii: usize, jj: usize, kk: usize| ok.then(|| self.index(ii, jj, kk));
        [
            (at(k + 1 < nz, i, j, k + 1), FRONT, BACK),
            (at(k > 0, i, j, k.wrapping_sub(1)), BACK, FRONT),
            (at(i + 1 < nx, i + 1, j, k), SIDE, SIDE),
            (at(i > 0, i.wrapping_sub(1), j, k), SIDE, SIDE),
            (at(j + 1 < ny, i, j + 1, k), SIDE, SIDE),
            (at(j > 0, i, j.wrapping_sub(1), k), SIDE, SIDE),
        ]
    }
}

/// Per cell and patch, the halves of Eq. 2's transmittance `exp(−σ_a ℓ)` and of Eq. 4's
/// factor `g^{σ_s ℓ}`, ℓ the distance from the cell's centre to its face on that patch's
/// side: the factor between two neighbours is the product of their halves (the mean
/// coefficients of the two cells over the centre distance).
pub trait HalfSteps: Sync {
    /// Number of cells.
    fn len(&self) -> usize;
    /// Whether there are no cells.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// `exp(−σ_a ℓ)` of cell `c` towards its patch `which`.
    fn t(&self, c: usize, which: u8) -> f64;
    /// `g^{σ_s ℓ}` of cell `c` towards its patch `which`.
    fn g(&self, c: usize, which: u8) -> f64;
}

/// The same half-step towards every neighbour (the light-aligned grid: h/2).
#[derive(Clone, Debug, PartialEq)]
pub struct UniformHalves {
    /// `exp(−σ_a ℓ)` per cell.
    pub t: Vec<f64>,
    /// `g^{σ_s ℓ}` per cell.
    pub g: Vec<f64>,
}

impl HalfSteps for UniformHalves {
    fn len(&self) -> usize {
        self.t.len().min(self.g.len())
    }

    #[inline(always)]
    fn t(&self, c: usize, _which: u8) -> f64 {
        self.t[c]
    }

    #[inline(always)]
    fn g(&self, c: usize, _which: u8) -> f64 {
        self.g[c]
    }
}

impl HalfSteps for Halves {
    fn len(&self) -> usize {
        self.t.len().min(self.g.len())
    }

    #[inline]
    fn t(&self, c: usize, which: u8) -> f64 {
        self.t[c][which as usize]
    }

    #[inline]
    fn g(&self, c: usize, which: u8) -> f64 {
        self.g[c][which as usize]
    }
}

/// Per cell and patch ([`FRONT`], [`SIDE`], [`BACK`], the index) the halves of
/// [`HalfSteps`], where the half-steps differ between the patches (the radial grid).
#[derive(Clone, Debug, PartialEq)]
pub struct Halves {
    /// `exp(−σ_a ℓ)` per cell and patch.
    pub t: Vec<[f64; 3]>,
    /// `g^{σ_s ℓ}` per cell and patch.
    pub g: Vec<[f64; 3]>,
}

/// The iteration of [`propagate_scheduled`] on any [`Stencil`]: `source` holds the initial
/// magnitudes, `power` converts a sum of magnitudes into power for the bookkeeping (h² on
/// the light-aligned grid, 1 where the magnitudes are powers already).
pub fn propagate_on<S: Stencil, H: HalfSteps>(
    grid: &S,
    halves: &H,
    power: f64,
    source: &[f64],
    initial_anisotropy: f64,
    lmax: usize,
    schedule: Schedule,
) -> anyhow::Result<Propagated> {
    let n = grid.cells();
    ensure!(
        source.len() == n && halves.len() == n,
        "POP: source ({}) and halves ({}) do not fit the grid's {n} cells",
        source.len(),
        halves.len()
    );
    let nb = lmax + 1;
    let mut bands = vec![0.0; n * nb];
    let mut l_cur = source.to_vec();
    let mut a_cur = vec![initial_anisotropy; n];
    accumulate(&mut bands, &l_cur, &a_cur, nb, 0.5);
    let mut l_next = vec![0.0; n];
    let mut a_next = vec![0.0; n];
    let injected = sum(&l_cur) * power;
    let [nx, ny, _] = grid.shape();
    let plane = nx * ny;
    let mut energy = Vec::new();
    let mut patches = vec![Patches::of(initial_anisotropy); n];
    let mut residuum: Option<ResiduumInfo> = None;
    let mut m = 0;
    loop {
        let in_flight = sum(&l_cur) * power;
        match schedule {
            Schedule::Fixed(iterations) if m == iterations => break,
            Schedule::Fixed(_) => {}
            Schedule::Residuum {
                anisotropic,
                epsilon_l,
                max_total,
            } => {
                if m == anisotropic && residuum.is_none() {
                    // §5.4: the lobes are nearly isotropic; drop their anisotropy (keeping
                    // the magnitudes) and go on with isotropic scattering only.
                    residuum = Some(switch_to_isotropic(
                        &mut a_cur, &l_cur, in_flight, injected, m,
                    ));
                    patches.fill(Patches::of(0.0));
                }
                if let Some(r) = residuum.as_mut() {
                    r.isotropic_iterations = m - r.switch_iteration;
                    r.reached_epsilon_l = in_flight <= epsilon_l * injected;
                    if r.reached_epsilon_l {
                        break;
                    }
                }
                if m == max_total {
                    break;
                }
            }
        }
        m += 1;
        if residuum.is_none() {
            // Isotropic lobes keep a = 0 and their patches (Eq. 3 at a = 0) once set.
            patches
                .par_iter_mut()
                .zip(a_cur.par_iter())
                .for_each(|(p, a)| *p = Patches::of(*a));
        }
        let cur = Buffers {
            l: &l_cur,
            a: &a_cur,
            patches: &patches,
            halves,
        };
        let sums: Vec<(f64, f64, f64)> = l_next
            .par_chunks_mut(plane)
            .zip(a_next.par_chunks_mut(plane))
            .zip(bands.par_chunks_mut(plane * nb))
            .enumerate()
            .map(|(k, ((lp, ap), bp))| {
                let (mut inflight, mut left, mut absorbed) = (0.0, 0.0, 0.0);
                for j in 0..ny {
                    for i in 0..nx {
                        let o = j * nx + i;
                        let c = k * plane + o;
                        let nbrs = grid.neighbours(i, j, k);
                        let (l, a) = cur.gather(c, &nbrs);
                        lp[o] = l;
                        ap[o] = a;
                        inflight += l;
                        let mut p = 1.0;
                        for b in &mut bp[o * nb..(o + 1) * nb] {
                            *b += l * p;
                            p *= a;
                        }
                        let (lf, ab) = cur.send(c, &nbrs);
                        left += lf;
                        absorbed += ab;
                    }
                }
                (inflight, left, absorbed)
            })
            .collect();
        let (inflight, left, absorbed) = sums
            .iter()
            .fold((0.0, 0.0, 0.0), |s, v| (s.0 + v.0, s.1 + v.1, s.2 + v.2));
        energy.push(IterationEnergy {
            iteration: m,
            in_flight_before: in_flight,
            left_grid: left * power,
            absorbed: absorbed * power,
            in_flight_after: inflight * power,
        });
        std::mem::swap(&mut l_cur, &mut l_next);
        std::mem::swap(&mut a_cur, &mut a_next);
    }
    Ok(Propagated {
        bands,
        lmax,
        injected,
        energy,
        residual: l_cur,
        residual_anisotropy: a_cur,
        residuum,
    })
}

/// The checks of [`propagate_scheduled`]'s inputs: the schedule's settings, the medium and
/// source on the grid's cells, g and the initial anisotropy in range, finite non-negative
/// values.
pub(crate) fn check_inputs(
    n: usize,
    medium: &PopMedium,
    source: &[f64],
    initial_anisotropy: f64,
    schedule: Schedule,
) -> anyhow::Result<()> {
    if let Schedule::Residuum {
        epsilon_l,
        max_total,
        anisotropic,
    } = schedule
    {
        ensure!(
            epsilon_l.is_finite() && epsilon_l > 0.0 && epsilon_l < 1.0,
            "POP: the residuum's epsilon_l must lie in (0, 1), got {epsilon_l}"
        );
        ensure!(
            anisotropic <= max_total,
            "POP: {anisotropic} anisotropic iterations exceed the cap of {max_total}"
        );
    }
    ensure!(
        medium.sigma_s.len() == n && medium.sigma_a.len() == n && source.len() == n,
        "POP: medium ({} / {}) and source ({}) do not fit the grid's {n} cells",
        medium.sigma_s.len(),
        medium.sigma_a.len(),
        source.len()
    );
    ensure!(
        medium.g.is_finite() && (0.0..1.0).contains(&medium.g),
        "POP: the phase function's g must lie in [0, 1), got {}",
        medium.g
    );
    ensure!(
        (0.0..=1.0).contains(&initial_anisotropy),
        "POP: the initial anisotropy must lie in [0, 1], got {initial_anisotropy}"
    );
    for (name, v) in [
        ("sigma_s", medium.sigma_s.as_slice()),
        ("sigma_a", medium.sigma_a.as_slice()),
        ("source", source),
    ] {
        if let Some(bad) = v.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
            anyhow::bail!("POP: {name} holds {bad}, not a finite non-negative value");
        }
    }
    Ok(())
}

fn sum(v: &[f64]) -> f64 {
    v.iter().sum()
}

/// Makes every lobe isotropic (a = 0) after iteration `m` and records the state at the switch.
fn switch_to_isotropic(
    a: &mut [f64],
    l: &[f64],
    in_flight: f64,
    injected: f64,
    m: usize,
) -> ResiduumInfo {
    let total: f64 = sum(l);
    let weighted: f64 = l.iter().zip(a.iter()).map(|(l, a)| l * a).sum();
    let lmax = l.iter().fold(0.0f64, |x, v| x.max(*v));
    let max_a = l
        .iter()
        .zip(a.iter())
        .filter(|(l, _)| **l >= 1e-3 * lmax && **l > 0.0)
        .map(|(_, a)| *a)
        .fold(0.0f64, f64::max);
    a.fill(0.0);
    ResiduumInfo {
        switch_iteration: m,
        mean_anisotropy_at_switch: if total > 0.0 { weighted / total } else { 0.0 },
        max_anisotropy_at_switch: max_a,
        in_flight_fraction_at_switch: if injected > 0.0 {
            in_flight / injected
        } else {
            0.0
        },
        isotropic_iterations: 0,
        reached_epsilon_l: false,
    }
}

/// `bands[c·nb + l] += w · L_c · a_c^l`.
fn accumulate(bands: &mut [f64], l: &[f64], a: &[f64], nb: usize, w: f64) {
    bands
        .par_chunks_mut(nb)
        .zip(l.par_iter().zip(a.par_iter()))
        .for_each(|(b, (l, a))| {
            let mut p = w * l;
            for v in b {
                *v += p;
                p *= a;
            }
        });
}

/// The read-only state of one iteration.
struct Buffers<'a, H> {
    l: &'a [f64],
    a: &'a [f64],
    patches: &'a [Patches],
    halves: &'a H,
}

impl<H: HalfSteps> Buffers<'_, H> {
    /// Eq. 5–6 for destination `dst` with neighbours `nbrs` ([`Stencil::neighbours`]): the
    /// gathered magnitude and anisotropy.
    #[inline(always)]
    fn gather(&self, dst: usize, nbrs: &[Neighbour; 6]) -> (f64, f64) {
        let (mut l, mut la) = (0.0, 0.0);
        // Each neighbour sends dst its patch that points at dst (on the light-aligned grid:
        // the neighbour in front its back patch, the one behind its front patch, the four
        // others a side patch), crossing its own half towards dst and dst's half towards it.
        for &(src, mine, theirs) in nbrs {
            let Some(s) = src else { continue };
            let ls = self.l[s];
            if ls == 0.0 {
                continue;
            }
            let frac = self.patches[s].towards(theirs);
            let (ts, td) = (self.halves.t(s, theirs), self.halves.t(dst, mine));
            let dl = ls * frac * ts * td;
            l += dl;
            let (gs, gd) = (self.halves.g(s, theirs), self.halves.g(dst, mine));
            la += dl * self.a[s] * gs * gd;
        }
        let a = if l > 0.0 {
            (la / l).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (l, a)
    }

    /// What source `src` sends out of the grid and what is absorbed on its six ways.
    #[inline(always)]
    fn send(&self, src: usize, nbrs: &[Neighbour; 6]) -> (f64, f64) {
        let ls = self.l[src];
        if ls == 0.0 {
            return (0.0, 0.0);
        }
        let p = &self.patches[src];
        let (mut left, mut absorbed) = (0.0, 0.0);
        for &(dst, mine, theirs) in nbrs {
            let sent = ls * p.towards(mine);
            let t = self.halves.t(src, mine) * dst.map_or(1.0, |d| self.halves.t(d, theirs));
            if dst.is_none() {
                left += sent * t;
            }
            absorbed += sent * (1.0 - t);
        }
        (left, absorbed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_grid_covers_the_box_and_is_aligned() {
        let d = [0.3, -1.0, 0.2];
        let g = LightGrid::around_box(d, [-1.0; 3], [1.0; 3], 16).unwrap();
        let dn = normalized(d);
        for (a, b) in g.axes[2].iter().zip(&dn) {
            assert!((a - b).abs() < 1e-15);
        }
        for a in 0..3 {
            for b in 0..3 {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((dot(g.axes[a], g.axes[b]) - want).abs() < 1e-14);
            }
        }
        assert_eq!(g.res.iter().max(), Some(&16));
        // Every corner of the box lies inside the grid (local coordinates in [−½, n − ½]).
        for c in 0..8 {
            let p = [0, 1, 2].map(|q| if c >> q & 1 == 1 { 1.0 } else { -1.0 });
            let x = g.local(p);
            for (x, n) in x.iter().zip(g.res) {
                assert!(*x >= -0.5 - 1e-9 && *x <= n as f64 - 0.5 + 1e-9);
            }
        }
        // centre and local are inverse.
        let x = g.local(g.centre([3, 5, 7]));
        assert!((x[0] - 3.0).abs() < 1e-12 && (x[1] - 5.0).abs() < 1e-12);
        assert!((x[2] - 7.0).abs() < 1e-12);
    }
}
