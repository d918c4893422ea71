//! Bilinear sampling of a face field at departure points, a row of faces at a time, on fields
//! padded with their ghosts so that no sample needs a branch.
//!
//! Padded layouts (x fastest, `stride` = nx + 2):
//! - u-like [ny + 2][nx + 2]: rows -1 ..= ny, columns 0 ..= nx + 1 (row -1 = -row 0 and
//!   row ny = -row ny-1, the no-slip mirrors; column nx + 1 repeats nx, the clamp);
//! - v-like [ny + 1][nx + 2]: rows 0 ..= ny, columns -1 ..= nx (column -1 = -column 0, the
//!   inlet mirror; column nx repeats nx - 1, the outlet).
//!
//! These are exactly the ghosts of [`Dim::fetch_u`] / [`Dim::fetch_v`] within the reach of a
//! clamped departure point, so a sample here equals [`Dim::stencil_u`] + [`bilerp`] bit for
//! bit. Where every face of a chunk of [`LANES`] departs into its own cell or the one before
//! it in x and in y (a local CFL number of at most about 1), the four corners are chosen
//! among nine neighbours loaded as whole rows (vector loads and selects instead of scattered
//! loads); any other chunk gathers each corner by its index.

use super::stencil::{Dim, bilerp, extrema};

/// Faces sampled together.
pub(crate) const LANES: usize = 8;

/// Which padded layout a field has.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Face {
    U,
    V,
}

/// A face field with its ghosts, as in the module header.
#[derive(Debug, Default, Clone)]
pub(crate) struct Padded {
    pub data: Vec<f32>,
    pub stride: usize,
}

impl Padded {
    pub fn resize(&mut self, d: &Dim, face: Face) {
        self.stride = d.nx + 2;
        let rows = match face {
            Face::U => d.ny + 2,
            Face::V => d.ny + 1,
        };
        self.data.resize(rows * self.stride, 0.0);
    }

    /// Index of stored u-like face (i, j), j in -1 ..= ny.
    #[inline(always)]
    pub fn at_u(&self, i: usize, j: isize) -> usize {
        (j + 1) as usize * self.stride + i
    }

    /// Index of stored v-like face (i, j), i in -1 ..= nx.
    #[inline(always)]
    pub fn at_v(&self, i: isize, j: usize) -> usize {
        j * self.stride + (i + 1) as usize
    }

    /// Fills the ghosts of a u-like field whose rows 0..ny, columns 0..=nx are set.
    pub fn fill_ghosts_u(&mut self, d: &Dim) {
        let (nx, ny, s) = (d.nx, d.ny, self.stride);
        for j in 0..ny {
            let r = (j + 1) * s;
            self.data[r + nx + 1] = self.data[r + nx];
        }
        for (ghost, edge) in [(0, s), ((ny + 1) * s, ny * s)] {
            for i in 0..s {
                self.data[ghost + i] = -self.data[edge + i];
            }
        }
    }

    /// Fills the ghosts of a v-like field whose rows 0..=ny, columns 0..nx are set.
    pub fn fill_ghosts_v(&mut self, d: &Dim) {
        let (nx, s) = (d.nx, self.stride);
        for j in 0..=d.ny {
            let r = j * s;
            self.data[r] = -self.data[r + 1];
            self.data[r + nx + 1] = self.data[r + nx];
        }
    }
}

/// One row's departure points, and room for the chunks off the fast path.
#[derive(Debug, Default, Clone)]
pub(crate) struct Departures {
    pub x: Vec<f32>,
    pub y: Vec<f32>,
    /// Offsets of the chunks that `sample_avx2` leaves to [`sample_chunk`].
    pub far: Vec<usize>,
}

impl Departures {
    pub fn resize(&mut self, n: usize) {
        self.x.resize(n, 0.0);
        self.y.resize(n, 0.0);
        self.far.resize(n / LANES + 1, 0);
    }
}

/// Where a row's samples go: `out[m]` for departure point m, and the stencil's (min, max)
/// into `lo[m]`, `hi[m]` unless those are empty; written straight into the caller's fields.
#[derive(Debug)]
pub(crate) struct Sink<'a> {
    pub out: &'a mut [f32],
    pub lo: &'a mut [f32],
    pub hi: &'a mut [f32],
}

impl<'a> Sink<'a> {
    /// The samples only.
    pub fn values(out: &'a mut [f32]) -> Self {
        Sink {
            out,
            lo: &mut [],
            hi: &mut [],
        }
    }

    /// The samples and their stencils' extrema.
    pub fn with_extrema(out: &'a mut [f32], lo: &'a mut [f32], hi: &'a mut [f32]) -> Self {
        Sink { out, lo, hi }
    }

    /// Whether the extrema are wanted.
    #[inline(always)]
    pub fn extrema(&self) -> bool {
        !self.lo.is_empty()
    }
}

/// Samples `a` at the departure points `r.x[..len]`, `r.y[..len]` of faces `first .. first
/// + len` of row `j` (faces of the kind `face`) into `sink` ([`Sink`]); `AVX2`: by
/// [`super::sample_avx2`] (the caller has checked [`super::simd::avx2`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_row<const AVX2: bool>(
    d: &Dim,
    a: &Padded,
    face: Face,
    j: usize,
    first: usize,
    len: usize,
    r: &mut Departures,
    sink: Sink,
) {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: AVX2 is present (the caller's check).
        return unsafe { super::sample_avx2::sample_row(d, a, face, j, first, len, r, sink) };
    }
    let mut sink = sink;
    let last_fast = fast_end(d, face);
    let mut n = 0;
    while n + LANES <= len && first + n + LANES <= last_fast {
        sample_chunk(d, a, face, j, first + n, n, r, &mut sink);
        n += LANES;
    }
    for m in n..len {
        sample_one(d, a, face, m, r, &mut sink);
    }
}

/// One past the last face a chunk may reach and still find its nine neighbours stored: u
/// faces load columns i - 1 ..= i + 1 of 0 ..= nx + 1; v faces those of -1 ..= nx.
#[inline(always)]
pub(super) fn fast_end(d: &Dim, face: Face) -> usize {
    match face {
        Face::U => d.nx + 1,
        Face::V => d.nx,
    }
}

/// The sample (and extrema) of the departure point `m` of a row, by gathering its corners.
#[inline(always)]
pub(super) fn sample_one(
    d: &Dim,
    a: &Padded,
    face: Face,
    m: usize,
    r: &Departures,
    sink: &mut Sink,
) {
    let (corner, t) = corner(d, face, r.x[m], r.y[m]);
    let vals = gather(a, face, corner);
    sink.out[m] = bilerp(vals, t);
    if sink.extrema() {
        [sink.lo[m], sink.hi[m]] = extrema(vals);
    }
}

/// The stencil corner and weights of a departure point, as [`Dim::corner_u`] /
/// [`Dim::corner_v`].
#[inline(always)]
fn corner(d: &Dim, face: Face, x: f32, y: f32) -> ([i32; 2], [f32; 2]) {
    match face {
        Face::U => d.corner_u(x, y),
        Face::V => d.corner_v(x, y),
    }
}

/// The four corner values of a stencil from the padded field, by index.
#[inline(always)]
fn gather(a: &Padded, face: Face, [i0, j0]: [i32; 2]) -> [f32; 4] {
    let k = match face {
        Face::U => a.at_u(i0 as usize, j0 as isize),
        Face::V => a.at_v(i0 as isize, j0 as usize),
    };
    let s = a.stride;
    [a.data[k], a.data[k + 1], a.data[k + s], a.data[k + s + 1]]
}

/// [`LANES`] faces from `i` (row `j`), departure points at `r.x[n..]`, `r.y[n..]`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
#[allow(clippy::needless_range_loop)] // lanes of parallel arrays, indexed together
pub(super) fn sample_chunk(
    d: &Dim,
    a: &Padded,
    face: Face,
    j: usize,
    i: usize,
    n: usize,
    r: &Departures,
    sink: &mut Sink,
) {
    let mut c = [[0i32; 2]; LANES];
    let mut t = [[0.0f32; 2]; LANES];
    for l in 0..LANES {
        (c[l], t[l]) = corner(d, face, r.x[n + l], r.y[n + l]);
    }
    // Offsets of the lower-left corner from the face itself: -1 or 0 on the fast path.
    let mut near = true;
    for l in 0..LANES {
        let ox = c[l][0] - (i + l) as i32;
        let oy = c[l][1] - j as i32;
        near &= (ox == -1 || ox == 0) & (oy == -1 || oy == 0);
    }
    let mut vals = [[0.0f32; 4]; LANES];
    if near {
        // Rows j - 1, j, j + 1 at columns i - 1, i, i + 1 (one load of LANES per pair).
        let base = match face {
            Face::U => a.at_u(i - 1, j as isize - 1),
            Face::V => a.at_v(i as isize - 1, j - 1),
        };
        let s = a.stride;
        let row = |q: usize, dc: usize| -> &[f32; LANES] {
            let k = base + q * s + dc;
            a.data[k..k + LANES].try_into().expect("LANES values")
        };
        let nb = [
            [row(0, 0), row(0, 1), row(0, 2)],
            [row(1, 0), row(1, 1), row(1, 2)],
            [row(2, 0), row(2, 1), row(2, 2)],
        ];
        for l in 0..LANES {
            let left = c[l][0] < (i + l) as i32;
            let below = c[l][1] < j as i32;
            // Per row q: the stencil's left and right values.
            let pick = |q: usize| {
                if left {
                    [nb[q][0][l], nb[q][1][l]]
                } else {
                    [nb[q][1][l], nb[q][2][l]]
                }
            };
            let (r0, r1, r2) = (pick(0), pick(1), pick(2));
            let (lo, up) = if below { (r0, r1) } else { (r1, r2) };
            vals[l] = [lo[0], lo[1], up[0], up[1]];
        }
    } else {
        for l in 0..LANES {
            vals[l] = gather(a, face, c[l]);
        }
    }
    for l in 0..LANES {
        sink.out[n + l] = bilerp(vals[l], t[l]);
    }
    if sink.extrema() {
        for l in 0..LANES {
            [sink.lo[n + l], sink.hi[n + l]] = extrema(vals[l]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::sim::batch_params;

    fn dim(nx: u32, ny: u32) -> Dim {
        let sets: Vec<String> = [
            format!("domain.nx={nx}"),
            format!("domain.ny={ny}"),
            format!("domain.length_m={}", nx as f64 * 1e-4),
            format!("domain.height_m={}", ny as f64 * 1e-4),
            format!("domain.success_x_m={}", nx as f64 * 0.2e-4),
            format!("domain.failure_x_m={}", nx as f64 * 0.8e-4),
            "swarm.count=0".into(),
        ]
        .to_vec();
        let r = Config::load(None, &sets).unwrap();
        Dim::new(&batch_params(&r, 1))
    }

    fn noise(n: usize, seed: u32) -> Vec<f32> {
        (0..n)
            .map(|k| (((k as u32).wrapping_mul(2654435761) ^ seed) % 2001) as f32 / 1000.0 - 1.0)
            .collect()
    }

    /// Every sample, near (fast path) or far (gather), on awkward sizes and at the walls,
    /// inlet and outlet, equals the unpadded stencil of `Dim` bit for bit.
    #[test]
    fn padded_samples_equal_the_ghost_mapped_stencil() {
        for (nx, ny) in [(13, 7), (37, 20), (8, 3), (64, 5)] {
            let d = dim(nx, ny);
            for face in [Face::U, Face::V] {
                let (n, first, rows) = match face {
                    Face::U => (d.n_u(), 1, 0..d.ny),
                    Face::V => (d.n_v(), 0, 1..d.ny),
                };
                let field = noise(n, nx * 31 + ny);
                let mut pad = Padded::default();
                pad.resize(&d, face);
                for j in 0..=d.ny {
                    for i in 0..=d.nx {
                        let (k, stored) = match face {
                            Face::U if j < d.ny => (pad.at_u(i, j as isize), j * (d.nx + 1) + i),
                            Face::V if i < d.nx => (pad.at_v(i as isize, j), j * d.nx + i),
                            _ => continue,
                        };
                        pad.data[k] = field[stored];
                    }
                }
                match face {
                    Face::U => pad.fill_ghosts_u(&d),
                    Face::V => pad.fill_ghosts_v(&d),
                }
                let len = d.nx;
                let mut r = Departures::default();
                r.resize(len);
                // Departures within a cell (fast chunks) and up to 3 cells away (gathers),
                // and beyond the walls and ends (clamped).
                for (reach, seed) in [(0.9f32, 1u32), (3.0, 2), (0.2, 3), (40.0, 4)] {
                    for j in rows.clone() {
                        let jitter = noise(2 * len, seed * 977 + j as u32);
                        for m in 0..len {
                            let i = first + m;
                            let [x0, y0] = match face {
                                Face::U => d.u_pos(i, j),
                                Face::V => d.v_pos(i, j),
                            };
                            r.x[m] = x0 + reach * jitter[2 * m] * d.p.dx;
                            r.y[m] = y0 + reach * jitter[2 * m + 1] * d.p.dy;
                        }
                        let [mut out, mut lo, mut hi] = [0; 3].map(|_| vec![f32::NAN; len]);
                        let sink = Sink::with_extrema(&mut out, &mut lo, &mut hi);
                        sample_row::<false>(&d, &pad, face, j, first, len, &mut r, sink);
                        let mut alone = vec![f32::NAN; len];
                        sample_row::<false>(
                            &d,
                            &pad,
                            face,
                            j,
                            first,
                            len,
                            &mut r,
                            Sink::values(&mut alone),
                        );
                        assert_eq!(alone, out, "{face:?} samples without extrema");
                        #[cfg(target_arch = "x86_64")]
                        if crate::sim::cpu::simd::avx2() {
                            let [mut o, mut l, mut h] = [0; 3].map(|_| vec![f32::NAN; len]);
                            let sink = Sink::with_extrema(&mut o, &mut l, &mut h);
                            sample_row::<true>(&d, &pad, face, j, first, len, &mut r, sink);
                            for m in 0..len {
                                assert_eq!(o[m].to_bits(), out[m].to_bits());
                                assert_eq!(l[m].to_bits(), lo[m].to_bits());
                                assert_eq!(h[m].to_bits(), hi[m].to_bits());
                            }
                            let sink = Sink::values(&mut alone);
                            sample_row::<true>(&d, &pad, face, j, first, len, &mut r, sink);
                            assert_eq!(alone, out, "{face:?} AVX2 samples without extrema");
                        }
                        for m in 0..len {
                            let (vals, t) = match face {
                                Face::U => d.stencil_u(&field, r.x[m], r.y[m]),
                                Face::V => d.stencil_v(&field, r.x[m], r.y[m]),
                            };
                            let want = bilerp(vals, t);
                            assert_eq!(out[m].to_bits(), want.to_bits(), "{face:?} {i}", i = m);
                            assert_eq!([lo[m], hi[m]], extrema(vals));
                        }
                    }
                }
            }
        }
    }
}
