//! Building a key: its strings loaded by the board, the hammers' sub-step
//! plans, the unison's trade, the phantom products, the partials the other
//! strings meet; and probing it to voice it through the body.

use super::*;

impl Key {
    /// Build every table the key will need on a `kind`, for touches up to its
    /// touch range's top, its strings loaded by `board` (None: by the design's
    /// resistive bridge).
    /// Allocates; off the audio thread.
    pub fn build(
        design: KeyDesign,
        sample_rate_hz: f64,
        kind: InstrumentKind,
        board: Option<&BoardLoad>,
    ) -> Result<Self, StringError> {
        let (touch, hand_mallets) = (kind.touch_range(), kind.hand_mallets());
        let mut notes = vec![Note {
            midi_key: design.midi_key,
            struck: design.struck.clone(),
            exciter: design.exciter,
            pitch_ratio: 1.0,
            substeps: None,
            hysteresis: design.hammer_hysteresis,
        }];
        notes.extend(design.shared.iter().map(|s| Note {
            midi_key: s.midi_key,
            struck: s.struck.clone(),
            exciter: s.exciter,
            pitch_ratio: s.pitch_ratio,
            substeps: None,
            hysteresis: design.hammer_hysteresis,
        }));
        notes.truncate(MAX_NOTES);
        let mut modes = design.strings.iter().map(|spec| spec.build()).collect::<Result<Vec<_>, _>>()?;
        // A course's strings trade energy through the board where they bear
        // together (a dulcimer's courses already move their bridge point).
        // A tangent holds its strings where it stops them, and moves them
        // itself: they do not trade freely.
        let coupled = board.is_some()
            && (2..=MAX_UNISON).contains(&modes.len())
            && design.bridge_coupling_s_kg <= 0.0
            && !matches!(design.exciter, ExciterDesign::Tangent { .. });
        let mut unison = Vec::new();
        if let Some(board) = board {
            let n = if coupled { modes.len() } else { 1 };
            if coupled {
                let step_s = (TRADE_BLOCKS * CONTROL_BLOCK) as f64 / sample_rate_hz;
                let eps = board.coupling(design.midi_key, design.resistive_bridge, &modes[0]);
                let partials = modes.iter().map(|m| m.modes.len()).min().unwrap_or(0).min(eps.len());
                unison = eps[..partials].iter().map(|&e| unison_step(e, n, step_s)).collect();
            }
            for string in &mut modes {
                let alone: Vec<f64> = string.modes.iter().map(|m| m.decay_rate_s()).collect();
                board.load(design.midi_key, design.resistive_bridge, n, string);
                if design.bridge_coupling_s_kg > 0.0 {
                    // Strings moving each other through a bridge point of
                    // resistance Re Y (sample by sample, `render_coupled`)
                    // lose at least what that resistance takes from each
                    // alone: where the board under it takes less (between
                    // its resonances) the others' pull would outweigh the
                    // string's own loss, and a course strung tight enough
                    // for its bridge losses to outweigh the wire's would
                    // grow (a dulcimer tuned an octave a key did).
                    for (mode, &rate_s) in string.modes.iter_mut().zip(&alone) {
                        if mode.decay_rate_s() < rate_s {
                            mode.q = mode.omega_rad_s / (2.0 * rate_s);
                        }
                    }
                }
            }
        }
        let phantom = match (board, design.exciter, modes.get(design.struck.start)) {
            (Some(_), ExciterDesign::Hammer { .. }, Some(lead)) if design.midi_key <= LAST_PHANTOM_KEY => {
                Some(PhantomTable::new(lead, 0.5 * sample_rate_hz)).filter(|t| !t.is_empty()).map(Phantom::new)
            }
            _ => None,
        };
        // The action sounds through the body (the bridge-force output is the
        // seed's strings alone). A hand-held mallet has no key; a tangent is
        // the key's stop.
        let on_body = board.is_some();
        let key_bed = on_body && matches!(design.exciter, ExciterDesign::Hammer { .. }) && !hand_mallets;
        let ports = match (board, design.exciter) {
            (Some(board), ExciterDesign::Hammer { .. } | ExciterDesign::Pluck { .. }) => {
                ports(board, design.midi_key, design.resistive_bridge, &modes)
            }
            _ => Vec::new(),
        };
        // Each hammer's strikes measured on the last string it reaches, with its
        // share of the hammer (as `press` splits it; an uneven hammer's
        // narrowest and widest shares, the worse of the two at each speed).
        let shares = &design.strike_shares;
        for note in &mut notes {
            if let (ExciterDesign::Hammer { mass_kg, law, position }, Some(last), Some(top_speed_m_s)) =
                (note.exciter, note.struck.clone().last(), touch.top_speed_m_s())
            {
                let plan = |share: f64| {
                    let law = ContactLaw { stiffness: law.stiffness * share, ..law };
                    let hammer = HammerSpec::one_of(note.struck.len(), mass_kg * share, law, top_speed_m_s, position)
                        .with_hysteresis(note.hysteresis);
                    SubstepPlan::measure(&modes[last], sample_rate_hz, hammer)
                };
                let met: Vec<f64> = note.struck.clone().filter_map(|i| shares.get(i).copied()).collect();
                let (narrowest, widest) = met.iter().fold((1.0f64, 1.0f64), |(n, w), &s| (n.min(s), w.max(s)));
                note.substeps = Some(if met.is_empty() { plan(1.0) } else { plan(widest).worse_of(plan(narrowest)) });
            }
        }
        let mut strings = Vec::with_capacity(design.strings.len());
        for (i, string) in modes.into_iter().enumerate() {
            let counts: Vec<usize> = notes
                .iter()
                .filter(|n| n.struck.contains(&i))
                .filter_map(|n| n.substeps.as_ref())
                .flat_map(SubstepPlan::counts)
                .collect();
            let mut s = StruckString::with_substep_counts(string, sample_rate_hz, &counts);
            for note in notes.iter().filter(|n| n.struck.contains(&i)) {
                match note.exciter {
                    ExciterDesign::Hammer { position, .. } => s.prepare_hammer(position),
                    ExciterDesign::Tangent { .. } => s.prepare_tangent(),
                    ExciterDesign::Pluck { position } => s.prepare_pluck(position),
                }
            }
            if design.bridge_coupling_s_kg > 0.0 {
                s.prepare_bridge_drive();
            }
            strings.push(s);
        }
        let room = strings.iter().map(|s| s.bank().len().next_multiple_of(LANES)).sum::<usize>()
            + phantom.as_ref().map_or(0, Phantom::room);
        Ok(Self {
            midi_key: design.midi_key,
            run: FreeRun {
                gather: FreeGather::with_room(room),
                gathered: vec![None; strings.len()],
                live: false,
                free_now: vec![false; strings.len()],
                lanes: Box::new([[0.0; LANES]; CONTROL_BLOCK]),
            },
            strings,
            notes,
            strike: StrikeShares { shares: design.strike_shares.clone(), hand_held: hand_mallets, strokes: 0 },
            damper: Damper::new(design.damper),
            unison: Unison { steps: unison, blocks_since_trade: 0 },
            driven: 0,
            phantom: PhantomState::new(phantom),
            action: ActionSounds {
                key_bed,
                on_body,
                bed_pulse: None,
                bed: action::KeyBedPulse::new(sample_rate_hz),
                noise: ActionNoise::default(),
            },
            ports,
            course: CourseBridge {
                coupling_s_kg: design.bridge_coupling_s_kg.max(0.0),
                share: 1.0,
                force_n: vec![0.0; design.strings.len()],
                force_now_n: vec![0.0; design.strings.len()],
            },
            gain_per_n: design.gain_per_n,
            bridge_point: BridgePoint::panned(design.pan),
            body_gain: 1.0,
            body_boost: if design.gain_per_n > 0.0 {
                (design.ring_gain_per_n / design.gain_per_n).max(1.0)
            } else {
                1.0
            },
            regulation: Regulation {
                table: Vec::new(),
                gain: 1.0,
                gain_to: 1.0,
                glide: 1.0 - (-1.0 / (STRIKE_GAIN_GLIDE_S * sample_rate_hz)).exp(),
            },
            active: false,
            held: 0,
            sounded: 0,
            sostenuto: false,
            speaking: 0,
            finger: Finger { pressure: 0.0, pressure_now: 0.0, bebung_cents: 0.0, bebung: 1.0 },
            trim: Trim { tune: 1.0, volume: 1.0, volume_to: 1.0, volume_step: 0.0, pan: KeyPan::default() },
            voicing: OwnVoicing { hardness: 1.0, position: 1.0, live: LiveVoicing::default() },
            pitch_set: 1.0,
            fade: Fade { gain: 1.0, step: 0.0 },
            cull: Cull { level: 0.0, loudest_n: 0.0, due_in: 0, last: (0.0, 0.0) },
        })
    }

    /// Play its first note at `touch` alone for `force.len()` samples, writing
    /// the force it hands the bridge (at its output gain), and return what its
    /// strings then ring with, string by string and mode by mode: the force
    /// Re(z e^(lambda t)) at output gain, as (z, lambda). The key is left silent. Allocates; for
    /// voicing the key through the body when the instrument is built.
    pub fn probe(&mut self, touch: Touch, force: &mut [f64]) -> Vec<Vec<(Complex64, Complex64)>> {
        self.settle();
        self.press(0, touch, &PerformanceState::default());
        for (b, chunk) in force.chunks_mut(CONTROL_BLOCK).enumerate() {
            chunk.fill(0.0);
            if b > 0 {
                // At each control tick, as the synth does: a string whose hammer
                // flies clear turns freely from there (the same to rounding).
                self.settle();
                self.strings.iter_mut().for_each(StruckString::watch_hammer);
            }
            self.render(chunk, None);
            if chunk.len() == CONTROL_BLOCK && (b + 1) % TRADE_BLOCKS == 0 {
                self.trade_through_bridge(0.0);
            }
        }
        force.iter_mut().for_each(|f| *f *= self.gain_per_n);
        self.settle();
        let gain = self.gain_per_n;
        let partials = self
            .strings
            .iter()
            .map(|s| s.bank().bridge_partials().into_iter().map(|(z, lambda)| (z * gain, lambda)).collect())
            .collect();
        self.silence();
        self.sounded = 0;
        partials
    }
}

/// The partials of `modes` (a key's strings, loaded by `board` at `midi_key`'s
/// bridge point) as the other strings meet them: strings tuned alike grouped,
/// each group's partials below [`SYMPATHY_TOP_HZ`] with the first string's
/// pole. Allocates.
fn ports(board: &BoardLoad, midi_key: u8, resistive: ResistiveBridge, modes: &[StringModes]) -> Vec<Port> {
    let first = |m: &StringModes| m.modes.first().map_or(0.0, |p| p.omega_rad_s);
    let mut out = Vec::new();
    let mut grouped = 0u32;
    for (i, lead) in modes.iter().enumerate().take(8) {
        if grouped & (1 << i) != 0 {
            continue;
        }
        let strings = (i..modes.len().min(8))
            .filter(|&j| (first(&modes[j]) / first(lead) - 1.0).abs() < SAME_PITCH)
            .fold(0u8, |mask, j| mask | (1 << j));
        grouped |= strings as u32;
        let partials = (0..modes.len().min(8))
            .filter(|j| strings & (1 << j) != 0)
            .map(|j| modes[j].modes.len())
            .min()
            .unwrap_or(0);
        let reach = board.reach(resistive, lead);
        let eps = board.coupling(midi_key, resistive, lead);
        for (n, mode) in lead.modes.iter().enumerate().take(partials) {
            let f_hz = mode.omega_rad_s / std::f64::consts::TAU;
            if f_hz > SYMPATHY_TOP_HZ {
                break;
            }
            let sigma = if mode.q.is_finite() && mode.q > 0.0 { mode.omega_rad_s / (2.0 * mode.q) } else { 0.0 };
            out.push(Port {
                strings,
                partial: n,
                f_hz,
                lambda: Complex64::new(-sigma, mode.omega_rad_s),
                reach: reach[n],
                loss_s: eps[n].re.max(0.0),
            });
        }
    }
    out
}
