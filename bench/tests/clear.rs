//! The clearance test ([`TubeCache::gap_or_clear`]) against the full section reading, at random
//! points in and around a deformed generated colon: a point it calls clear must read deeper
//! than the reach in full, with the same sector, and a point it reads must read the same.

use lumen_detect::section::{Axial, Reading, TubeCache};
use lumen_detect::view::TubeView;
use lumen_detect::V3;
use lumen_scene::colon::{generate, ColonParams};
use lumen_scene::endoscope::Insertion;

/// xorshift64*: enough for scattering points, and the same on every machine.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32 / (1u64 << 24) as f32
    }
}

#[test]
fn a_point_called_clear_reads_deeper_than_the_reach_and_a_point_read_reads_the_same() {
    // A frame of the kinematic colonoscopy: the wall pressed and deformed at the bends.
    let colon = generate(&ColonParams::seeded(3));
    let frame = Insertion { escapes: true, ..Insertion::default() }.frames(&colon, 1, 900.0, 1.0, 3).next().unwrap();
    let mut data = Vec::new();
    frame.colon.write_state(&mut data);
    let spokes = frame.colon.spokes;
    let t = TubeView::new(&data, frame.colon.rings(), spokes, V3::zeros());
    let mut cache = TubeCache::default();
    cache.begin(t.rings, 0.5);
    let mut rng = Rng(0x5EED_C1EA);
    let (mut clear, mut read_deep, mut read, mut outside) = (0, 0, 0, 0);
    for _ in 0..20_000 {
        // A ring, a point on one of its spokes scaled 0 to 1.3 (a third of them past the wall
        // where it is 1.0 and over), shifted along the tube and sideways by up to 1.5 mm.
        let i = 1 + (rng.unit() * (t.rings - 3) as f32) as usize;
        let k = (rng.unit() * spokes as f32) as usize % spokes;
        let jitter = V3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5) * 3.0;
        let p = t.point(i) + t.spoke(i, k) * (1.3 * rng.unit()) + jitter;
        let Axial::In { seg, u } = cache.axial(&t, &p, i, 8) else { continue };
        let full = cache.gap(&t, &p, seg, u, None, 0);
        outside += (full.sd > 0.0) as u32;
        for reach in [0.5, 3.0, 6.5, 12.0] {
            match cache.gap_or_clear(&t, &p, seg, u, None, reach) {
                Reading::Clear { seg: s, k, rho2, size } => {
                    clear += 1;
                    assert!(full.sd < -reach, "clear at reach {reach} but the full reading is {} mm (point {p:?})", full.sd);
                    assert_eq!((s, k), (full.seg, full.k), "clear in another sector than the full reading's (point {p:?})");
                    assert_eq!((rho2, size), (full.rho2, full.size));
                }
                Reading::Gap(g) => {
                    read += 1;
                    assert_eq!(g, full, "a reading differs from the full one (point {p:?}, reach {reach})");
                    read_deep += (g.sd < -reach * 1.01) as u32;
                }
            }
        }
    }
    eprintln!("{clear} clear, {read} read ({read_deep} of them deeper than the reach), {outside} points outside");
    // Most deep points are called clear (the test saves work), points outside exist (the test
    // is asked about them) and none of them was called clear (the first assertion).
    assert!(clear > 30_000, "only {clear} clear readings");
    assert!(read_deep * 20 < clear, "{read_deep} deep points read in full against {clear} called clear");
    assert!(outside > 1_000, "only {outside} points outside the wall");
}
