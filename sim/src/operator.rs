//! The scripted operator: what the endoscopist's hands do at the proximal end.
//!
//! **Units**: millimetres, seconds, radians inside (degrees in the script), newtons for the
//! hand's force limit.
//!
//! The operator drives the handle end of the scope (its last control point) along the
//! insertion axis (the axis of the anus, pointing into the patient) by a compliant "hand": a
//! spring of stiffness `k_hand` between the handle's axial position `s_h` and a target `s*`,
//! whose force is capped at the phase's limit `F_max` (a hand pushes hard, not infinitely hard).
//! It also rolls the handle (turning the plane of the angulated tip, see [`crate::rod`]),
//! angulates the distal bending section, and in the hard push holds the tip where it is, as a
//! tip caught at a bend, while the handle is forced in.
//!
//! A script is a list of [`Phase`]s, each an [`Action`] for a duration; the target is
//! re-anchored to the handle's actual position at the start of every phase (so a push the
//! wall stopped is not carried into the next phase). After the last phase the script repeats
//! from [`Script::repeat_from`].

/// What the hands do during one phase.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// Keep the handle where it is.
    Hold,
    /// Move the handle along the insertion axis at this speed (negative: pull back), mm/s.
    Insert { mm_per_s: f64 },
    /// Angulate the bending section linearly to this angle by the end of the phase, degrees.
    Angulate { to_deg: f64 },
    /// Roll the handle about the insertion axis at this rate, degrees/s.
    Twist { deg_per_s: f64 },
    /// The hard push: drive the handle in at `mm_per_s` with a hand force of up to `force_n`,
    /// holding the tip where it was when the phase began if `hold_tip`.
    Push { mm_per_s: f64, force_n: f64, hold_tip: bool },
}

/// One step of a script.
#[derive(Debug, Clone, PartialEq)]
pub struct Phase {
    pub name: &'static str,
    pub duration_s: f64,
    pub action: Action,
}

/// A script and the force limit of its ordinary phases.
#[derive(Debug, Clone, PartialEq)]
pub struct Script {
    pub phases: Vec<Phase>,
    /// Phase the script repeats from once it has run out.
    pub repeat_from: usize,
    /// The hand's force limit outside [`Action::Push`], N (default 15).
    pub force_n: f64,
}

impl Script {
    /// The default 3 s colonoscopy manoeuvre (3,000 frames at 1 kHz): settle, insert at 4 cm/s,
    /// pull back, angulate and twist the tip, straighten, then the hard push (25 cm/s, up to
    /// 40 N, tip held at the bend); repeats from the insertion.
    pub fn colonoscopy() -> Self {
        let p = |name, duration_s, action| Phase { name, duration_s, action };
        Self {
            phases: vec![
                p("settle", 0.15, Action::Hold),
                p("insert", 0.85, Action::Insert { mm_per_s: 40.0 }),
                p("pull back", 0.35, Action::Insert { mm_per_s: -40.0 }),
                p("angulate", 0.15, Action::Angulate { to_deg: 60.0 }),
                p("twist", 0.3, Action::Twist { deg_per_s: 300.0 }),
                p("twist back", 0.3, Action::Twist { deg_per_s: -300.0 }),
                p("straighten", 0.1, Action::Angulate { to_deg: 0.0 }),
                p("hard push", 0.8, Action::Push { mm_per_s: 250.0, force_n: 40.0, hold_tip: true }),
            ],
            repeat_from: 1,
            force_n: 15.0,
        }
    }

    /// [`Script::colonoscopy`] compressed into 0.6 s (600 frames at 1 kHz), for tests: settle
    /// 50 ms, insert 100 ms, pull back 50 ms, angulate, twist 54 degrees and back, straighten,
    /// then 220 ms of the hard push.
    pub fn short_colonoscopy() -> Self {
        let p = |name, duration_s, action| Phase { name, duration_s, action };
        Self {
            phases: vec![
                p("settle", 0.05, Action::Hold),
                p("insert", 0.1, Action::Insert { mm_per_s: 40.0 }),
                p("pull back", 0.05, Action::Insert { mm_per_s: -40.0 }),
                p("angulate", 0.03, Action::Angulate { to_deg: 60.0 }),
                p("twist", 0.06, Action::Twist { deg_per_s: 900.0 }),
                p("twist back", 0.06, Action::Twist { deg_per_s: -900.0 }),
                p("straighten", 0.03, Action::Angulate { to_deg: 0.0 }),
                p("hard push", 0.22, Action::Push { mm_per_s: 250.0, force_n: 40.0, hold_tip: true }),
            ],
            repeat_from: 1,
            force_n: 15.0,
        }
    }

    /// Total duration of one pass, s.
    pub fn duration_s(&self) -> f64 {
        self.phases.iter().map(|p| p.duration_s).sum()
    }
}

/// What the operator asks of the scope over one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// Handle target along the insertion axis at the start and the end of the frame, mm
    /// (substeps interpolate linearly).
    pub target_mm: [f64; 2],
    /// The hand's force limit, N.
    pub force_n: f64,
    /// Handle roll, radians.
    pub roll: f64,
    /// Angulation of the bending section, radians.
    pub tip_bend: f64,
    /// Whether the tip is held (the hard push).
    pub hold_tip: bool,
    /// The phase this frame belongs to (index into the script).
    pub phase: usize,
}

/// Runs a [`Script`] frame by frame.
#[derive(Debug, Clone)]
pub struct Operator {
    script: Script,
    phase: usize,
    /// Time spent in the current phase, in frames (integer: no drift at phase boundaries).
    frame_in_phase: u64,
    started: bool,
    target: f64,
    roll: f64,
    bend: f64,
    bend_from: f64,
}

impl Operator {
    /// An operator running `script` from its first phase.
    ///
    /// # Panics
    /// If the script is empty or `repeat_from` is out of range.
    pub fn new(script: Script) -> Self {
        assert!(!script.phases.is_empty() && script.repeat_from < script.phases.len(), "a script needs phases and a valid repeat point");
        Self { script, phase: 0, frame_in_phase: 0, started: false, target: 0.0, roll: 0.0, bend: 0.0, bend_from: 0.0 }
    }

    /// The script.
    pub fn script(&self) -> &Script {
        &self.script
    }

    /// Name of the current phase.
    pub fn phase_name(&self) -> &'static str {
        self.script.phases[self.phase].name
    }

    /// The drive for the next frame of length `dt` (s), given the handle's axial position now
    /// (mm along the insertion axis).
    pub fn advance(&mut self, dt: f64, handle_mm: f64) -> Drive {
        let frames_of = |d: f64| ((d / dt).round() as u64).max(1);
        if self.started && self.frame_in_phase >= frames_of(self.script.phases[self.phase].duration_s) {
            self.phase += 1;
            if self.phase == self.script.phases.len() {
                self.phase = self.script.repeat_from;
            }
            self.frame_in_phase = 0;
        }
        if !self.started || self.frame_in_phase == 0 {
            self.target = handle_mm;
            self.bend_from = self.bend;
            self.started = true;
        }
        let ph = self.script.phases[self.phase].clone();
        let n = frames_of(ph.duration_s);
        let start = self.target;
        let mut force = self.script.force_n;
        let mut hold = false;
        match ph.action {
            Action::Hold => {}
            Action::Insert { mm_per_s } => self.target += mm_per_s * dt,
            Action::Angulate { to_deg } => {
                let f = (self.frame_in_phase + 1) as f64 / n as f64;
                self.bend = self.bend_from + (to_deg.to_radians() - self.bend_from) * f;
            }
            Action::Twist { deg_per_s } => self.roll += deg_per_s.to_radians() * dt,
            Action::Push { mm_per_s, force_n, hold_tip } => {
                self.target += mm_per_s * dt;
                force = force_n;
                hold = hold_tip;
            }
        }
        self.frame_in_phase += 1;
        Drive { target_mm: [start, self.target], force_n: force, roll: self.roll, tip_bend: self.bend, hold_tip: hold, phase: self.phase }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phases_follow_in_frames_and_repeat() {
        let mut op = Operator::new(Script::colonoscopy());
        let dt = 1e-3;
        let mut phases = Vec::new();
        for _ in 0..3000 {
            let d = op.advance(dt, 0.0);
            phases.push(d.phase);
        }
        assert_eq!(phases[0], 0);
        assert_eq!(phases[149], 0);
        assert_eq!(phases[150], 1);
        assert_eq!(phases[2199], 6);
        assert_eq!(phases[2200], 7);
        assert_eq!(phases[2999], 7);
        assert_eq!(op.advance(dt, 0.0).phase, 1);
        // A push's target is re-anchored to where the handle is.
        let mut op = Operator::new(Script::colonoscopy());
        for _ in 0..150 {
            op.advance(dt, 5.0);
        }
        let d = op.advance(dt, 7.0);
        assert_eq!(d.target_mm, [7.0, 7.0 + 0.04]);
    }
}
