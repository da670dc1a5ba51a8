//! The MCM engine: [`Mcm`] holds a run's [`Setup`] and its [`McmState`], and each
//! [`Mcm::step`] is one compression step (thesis sec. 2.2.1, 3.2): compress by Delta V, remove
//! the overlaps within the step's budget of moves, and on failure revert to the last
//! overlap-free configuration and halve Delta V. The driver (`driver.rs`) runs it to its end.

use super::setup::Setup;
use super::{
    check_box, compress, random_start_of, remove_overlaps, remove_overlaps_with, species, Packing,
    StepRecord,
};
use crate::error::invalid;
use crate::Result;

/// The complete state of an MCM run between two compression steps: everything the next step
/// depends on (the run uses no random numbers after the start), so a run continued from a
/// saved state ([`Mcm::resume`]) gives bitwise the same result as an uninterrupted one.
#[derive(Debug, Clone)]
pub struct McmState {
    /// The last overlap-free configuration.
    pub packing: Packing,
    /// Current volume step Delta V (D^3).
    pub delta_v: f64,
    /// Halvings of Delta V still allowed.
    pub halvings_left: u32,
    /// Accepted compression steps, in order.
    pub history: Vec<StepRecord>,
    /// Failed (reverted) compression steps.
    pub failed_steps: usize,
    /// Total particle moves over the run.
    pub total_tries: u64,
    /// Particle moves in the stage running (against its `stage_budget_per_particle`).
    pub stage_tries: u64,
    /// The last stage ended because its budget ran out (see [`McmResult::stage_budget_spent`]).
    pub stage_budget_spent: bool,
    /// The stage running (0: main, 1: final; see [`Setup::final_stage`]).
    pub stage: u32,
    /// None while running; Some(true) when jammed (halvings of the last stage spent),
    /// Some(false) at `max_steps`.
    pub finished: Option<bool>,
}

/// What one [`Mcm::step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepOutcome {
    /// The compressed configuration was made overlap-free and accepted.
    Accepted,
    /// The overlaps could not be removed: reverted, Delta V halved (or the next stage begun).
    Halved,
    /// The run is over (see [`McmState::finished`]).
    Finished,
}

/// The result of an MCM run.
#[derive(Debug, Clone)]
pub struct McmResult {
    /// The last overlap-free configuration.
    pub packing: Packing,
    /// Accepted compression steps, in order.
    pub history: Vec<StepRecord>,
    /// Failed (reverted) compression steps.
    pub failed_steps: usize,
    /// Total particle moves over the run.
    pub total_tries: u64,
    /// True when the run stopped because all halvings were spent (jammed) or the last stage's
    /// budget ran out, false when it hit `max_steps`.
    pub jammed: bool,
    /// True when the last stage ended because its `stage_budget_per_particle` ran out (its
    /// last step got less than a full step's budget and failed).
    pub stage_budget_spent: bool,
}

/// An MCM run: its setup (checked once, in the constructors) and its state.
#[derive(Debug, Clone)]
pub struct Mcm {
    setup: Setup,
    state: McmState,
    last: Option<StepOutcome>,
}

impl Mcm {
    /// A run from the random start of `setup` (random sequential addition at `phi0`, ChaCha8
    /// seeded with `seed`; [`random_start_of`]).
    pub fn new(setup: Setup) -> Result<Mcm> {
        setup.validate()?;
        let start = random_start_of(setup.container, setup.particles(), setup.phi0, setup.seed)?;
        Mcm::begin(setup, start)
    }

    /// A run from a given overlap-free configuration of the setup's particles and container.
    pub fn from_start(setup: Setup, start: Packing) -> Result<Mcm> {
        setup.validate()?;
        Mcm::begin(setup, start)
    }

    /// The run of a checked setup from `start`.
    fn begin(setup: Setup, start: Packing) -> Result<Mcm> {
        check_matches(&setup, &start)?;
        let mut packing = start;
        // The start must itself be overlap-free.
        if remove_overlaps(&mut packing, &setup, 0)?.is_err() {
            return invalid("start configuration has overlaps deeper than overlap_tol");
        }
        let state = McmState {
            delta_v: setup.delta_v_per_particle * packing.n() as f64,
            packing,
            halvings_left: setup.halvings,
            history: Vec::new(),
            failed_steps: 0,
            total_tries: 0,
            stage_tries: 0,
            stage_budget_spent: false,
            stage: 0,
            finished: None,
        };
        Ok(Mcm {
            setup,
            state,
            last: None,
        })
    }

    /// A run continued from a saved state (a checkpoint) of the same setup: the particles and
    /// the container must be the setup's, the stage one of its stages.
    pub fn resume(setup: Setup, state: McmState) -> Result<Mcm> {
        setup.validate()?;
        check_matches(&setup, &state.packing)?;
        if state.stage >= setup.stages() {
            return invalid(format!(
                "saved state in stage {}: the setup has {} stage(s)",
                state.stage + 1,
                setup.stages()
            ));
        }
        Ok(Mcm {
            setup,
            state,
            last: None,
        })
    }

    /// The run's setup.
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// The run's state: the last overlap-free configuration and the schedule's progress.
    pub fn state(&self) -> &McmState {
        &self.state
    }

    /// What the last [`Mcm::step`] did (None before the first).
    pub fn last_outcome(&self) -> Option<StepOutcome> {
        self.last
    }

    pub fn is_done(&self) -> bool {
        self.state.finished.is_some()
    }

    /// One compression step (sec. 2.2.1, 3.2): compress by Delta V and remove the overlaps
    /// within `tries_per_particle` N moves; on failure revert to the last overlap-free
    /// configuration and halve Delta V, or begin the next stage, or finish when no halving is
    /// left.
    pub fn step(&mut self) -> Result<StepOutcome> {
        let o = self.state.step(&self.setup)?;
        self.last = Some(o);
        Ok(o)
    }

    /// The result: the last overlap-free configuration and the schedule's record.
    pub fn into_result(self) -> McmResult {
        let s = self.state;
        McmResult {
            packing: s.packing,
            history: s.history,
            failed_steps: s.failed_steps,
            total_tries: s.total_tries,
            jammed: s.finished == Some(true),
            stage_budget_spent: s.stage_budget_spent,
        }
    }
}

/// Refuses a configuration whose particles or container are not the setup's.
fn check_matches(setup: &Setup, p: &Packing) -> Result<()> {
    if p.particles != setup.particles() || p.container != setup.container {
        return invalid(format!(
            "start configuration: {} particles ({} species) in {:?} do not match the {} \
             particles and container {:?} of the setup",
            p.n(),
            p.particles.shapes.len(),
            p.container,
            setup.n,
            setup.container
        ));
    }
    Ok(())
}

impl McmState {
    /// See [`Mcm::step`]; `all` is the run's setup (both stages).
    fn step(&mut self, all: &Setup) -> Result<StepOutcome> {
        let prm = &all.stage_params(self.stage);
        if self.finished.is_some() {
            return Ok(StepOutcome::Finished);
        }
        if self.history.len() >= prm.max_steps {
            self.finished = Some(false);
            return Ok(StepOutcome::Finished);
        }
        let n = self.packing.n() as f64;
        let step_budget = (prm.tries_per_particle * n).ceil() as u64;
        let stage_budget = prm
            .stage_budget_per_particle
            .map_or(u64::MAX, |b| (b * n).ceil() as u64);
        let budget = step_budget.min(stage_budget.saturating_sub(self.stage_tries));
        let vp = self.packing.particles.total_volume()?;
        let props = species::props_of(&self.packing.particles)?;
        let trial =
            compress(&self.packing, self.delta_v).filter(|t| vp < t.container.volume(t.box_length));
        let outcome = match trial {
            None => None,
            Some(mut t) if budget > 0 => {
                check_box(&t.container, t.box_length, &props)?;
                let r = remove_overlaps_with(&mut t, &props, prm, budget)?;
                Some((t, r))
            }
            // The stage's budget is used up: a failed step without moves.
            Some(_) => None,
        };
        match outcome {
            Some((t, Ok(tries))) => {
                self.total_tries += tries;
                self.stage_tries += tries;
                self.packing = t;
                self.history.push(StepRecord {
                    step: self.history.len() + 1,
                    packing_fraction: self.packing.packing_fraction(),
                    delta_v: self.delta_v,
                    tries,
                });
                Ok(StepOutcome::Accepted)
            }
            other => {
                if let Some((_, Err(tries))) = other {
                    self.total_tries += tries;
                    self.stage_tries += tries;
                }
                self.failed_steps += 1;
                // Less than one step's budget was left for this step: the stage is over.
                let budget_spent = budget < step_budget;
                if self.halvings_left == 0 || budget_spent {
                    if self.stage + 1 < all.stages() {
                        self.stage += 1;
                        self.stage_tries = 0;
                        let next = all.stage_params(self.stage);
                        self.delta_v = next.delta_v_per_particle * n;
                        self.halvings_left = next.halvings;
                        return Ok(StepOutcome::Halved);
                    }
                    self.stage_budget_spent = budget_spent;
                    self.finished = Some(true);
                    return Ok(StepOutcome::Finished);
                }
                self.halvings_left -= 1;
                self.delta_v *= 0.5;
                Ok(StepOutcome::Halved)
            }
        }
    }
}
