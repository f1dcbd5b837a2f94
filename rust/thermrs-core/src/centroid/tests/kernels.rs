//! The window pass's sums against the row-by-row accumulation they replaced (every row
//! adding its ten terms to ten per-column sums in memory), bit for bit, through the route
//! the CPU takes (AVX2 where it has it) and the portable one.

use super::super::measure::{box_sums, box_sums_body, BoxPass, N_COLS};
use super::*;

/// The accumulation as first written: row after row, each term added to its column's sum.
fn row_by_row(p: &BoxPass) -> Vec<f32> {
    let BoxPass {
        vals,
        gx,
        gy,
        dyv,
        aa,
        nn,
        nxp,
    } = *p;
    let mut cols = vec![0.0f32; N_COLS * nxp];
    for (j, (&gyj, &dy)) in gy.iter().zip(dyv).enumerate() {
        let dy2 = dy * dy;
        for i in 0..nxp {
            let gg = gx[i] * gyj;
            let wgt = gg / (aa * gg + nn);
            let vv = vals[j * nxp + i];
            let (wv, wg, gv) = (wgt * vv, wgt * gg, gg * vv);
            let terms = [
                wv,
                wv * dy,
                wg,
                wg * dy,
                wg * dy2,
                gv,
                gv * dy,
                gv * dy2,
                gv * vv,
                gv * gg,
            ];
            for (k, t) in terms.iter().enumerate() {
                cols[k * nxp + i] += t;
            }
        }
    }
    cols
}

#[test]
fn window_sums_match_the_row_by_row_accumulation_bit_for_bit() {
    let mut rng = StdRng::seed_from_u64(17);
    for trial in 0..500 {
        let nx = rng.random_range(1..70usize);
        let ny = rng.random_range(1..70usize);
        let nxp = nx.div_ceil(LANES) * LANES;
        // Values of any sign and of magnitudes far apart, so that any change in the order of
        // the additions shows in the bits; the padding is zero, as in a pass.
        let mut any = |scale: i32| {
            rng.random_range(-1.0f32..1.0) * 2f32.powi(rng.random_range(-scale..scale))
        };
        let mut gx = vec![0.0f32; nxp];
        let mut vals = vec![0.0f32; ny * nxp];
        for i in 0..nx {
            gx[i] = any(8).abs();
            for j in 0..ny {
                vals[j * nxp + i] = any(12);
            }
        }
        let gy: Vec<f32> = (0..ny).map(|_| any(8).abs()).collect();
        let dyv: Vec<f32> = (0..ny).map(|_| any(6)).collect();
        let (aa, nn) = (any(4).abs(), any(4).abs() + 1e-3);
        let pass = BoxPass {
            vals: &vals,
            gx: &gx,
            gy: &gy,
            dyv: &dyv,
            aa,
            nn,
            nxp,
        };
        let want = row_by_row(&pass);
        let mut got = vec![f32::NAN; N_COLS * nxp];
        box_sums(&pass, &mut got);
        let mut portable = vec![f32::NAN; N_COLS * nxp];
        box_sums_body(&pass, &mut portable);
        for (k, ((w, g), p)) in want.iter().zip(&got).zip(&portable).enumerate() {
            assert_eq!(
                w.to_bits(),
                g.to_bits(),
                "trial {trial}, sum {k}: {w} vs {g}"
            );
            assert_eq!(
                w.to_bits(),
                p.to_bits(),
                "trial {trial}, sum {k} (portable)"
            );
        }
    }
}
