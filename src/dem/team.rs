//! Steps on two threads or more as one team between neighbour-list rebuilds.
//!
//! A step has three parallel loops (pair forces, the per-particle gather with the second half
//! kick, then the next step's first half kick and drift) separated by short serial work (the
//! walls' sums and the pressure controller). Run as three rayon loops, every loop hands its
//! work to threads that went to sleep in the few microseconds between loops, and waking them
//! costs more than a small bed's loop itself. In the team, the calling thread (the leader)
//! runs the steps and publishes each loop; helpers spawned on the pool's other threads spin
//! until a loop is published and take chunks of it. The leader takes chunks too, and waits
//! only for chunks that a helper has taken, so a helper whose thread is busy elsewhere (or
//! never starts) costs nothing but its share of the work.
//!
//! Each thread owns a run of consecutive chunks, the same in every loop, so that the pairs and
//! particles it handles stay in its core's caches from loop to loop; when its run is done it
//! takes what is left of the others. The chunks are those of [`Dem::step`]'s loops, and every
//! item's result is independent of the thread that computes it, so the steps are bitwise
//! those of [`Dem::step`] at any thread count.

use super::engine::{
    next_top_z, run_gather, run_kick_drift, run_pairs, task_len, Dem, GatherOut, KickOut,
    WallTotals,
};
use crate::Result;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Chunks per thread in each of the team's loops.
const TEAM_TASKS_PER_THREAD: usize = 4;

/// Spins of a waiting thread before it starts yielding its core at each check (a thread
/// descheduled by other work on the machine must not be kept from running).
const SPINS_BEFORE_YIELD: u32 = 1 << 14;

/// Spins until `ready()`.
#[inline]
fn spin_until(ready: impl Fn() -> bool) {
    let mut spins = 0u32;
    while !ready() {
        if spins < SPINS_BEFORE_YIELD {
            spins += 1;
            std::hint::spin_loop();
        } else {
            std::thread::yield_now();
        }
    }
}

/// A counter alone on its cache lines (two, for the adjacent-line prefetcher).
#[repr(align(128))]
struct Counter(AtomicU64);

/// The loop kinds, in their order in a step; loop number p (from 1) is of kind (p - 1) % 3.
const PAIRS: u64 = 0;
const GATHER: u64 = 1;
const KICK: u64 = 2;
/// The loop number that sends the helpers home.
const EXIT: u64 = u64::MAX;

/// What the leader publishes and the threads claim.
struct Board {
    /// The current loop's number (0: none yet; [`EXIT`]: done).
    loop_no: Counter,
    /// Per run: the loop number (high 32 bits) and the next chunk of the run (low 32 bits).
    next: Vec<Counter>,
    /// Chunks of the current loop completed.
    completed: Counter,
    /// Set when a thread's chunk panicked: the chunk never completes, so the leader stops
    /// waiting and ends the team, and the scope passes the panic on.
    failed: AtomicBool,
    /// The team thread whose first claimed chunk panics (tests of the failure path).
    #[cfg(test)]
    fail_thread: Option<usize>,
}

/// Sets its flag when dropped while the thread unwinds from a panic.
struct FlagOnPanic<'a>(&'a AtomicBool);

impl Drop for FlagOnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.store(true, Ordering::Release);
        }
    }
}

/// Sends the helpers home when the leader leaves the team, by return or by panic.
struct ExitOnDrop<'a>(&'a Board);

impl Drop for ExitOnDrop<'_> {
    fn drop(&mut self) {
        self.0.loop_no.0.store(EXIT, Ordering::Release);
    }
}

impl Board {
    fn new(threads: usize) -> Board {
        Board {
            loop_no: Counter(AtomicU64::new(0)),
            next: (0..threads).map(|_| Counter(AtomicU64::new(0))).collect(),
            completed: Counter(AtomicU64::new(0)),
            failed: AtomicBool::new(false),
            #[cfg(test)]
            fail_thread: None,
        }
    }

    /// Opens loop `no` (the leader, once the last one is complete).
    fn publish(&self, no: u64) {
        for c in &self.next {
            c.0.store(no << 32, Ordering::Relaxed);
        }
        self.completed.0.store(0, Ordering::Relaxed);
        self.loop_no.0.store(no, Ordering::Release);
    }

    /// The next chunk of run `t` of loop `no` (`chunks` chunks, `run` per thread), if any.
    fn claim(&self, no: u64, t: usize, run: usize, chunks: usize) -> Option<usize> {
        let c = &self.next[t].0;
        let mut cur = c.load(Ordering::Relaxed);
        loop {
            let j = (cur & 0xffff_ffff) as usize;
            if cur >> 32 != no || j >= run || run * t + j >= chunks {
                return None;
            }
            match c.compare_exchange_weak(cur, cur + 1, Ordering::Relaxed, Ordering::Relaxed) {
                Ok(_) => return Some(run * t + j),
                Err(now) => cur = now,
            }
        }
    }

    /// Runs `f` on the chunks thread `me` claims of loop `no`: its own run first, then the
    /// others'. `f` is built by `make` on the first claim (a thread that claims nothing reads
    /// nothing of the state).
    fn work<F: FnMut(usize)>(&self, no: u64, me: usize, chunks: usize, make: impl FnOnce() -> F) {
        let threads = self.next.len();
        let run = chunks.div_ceil(threads);
        let mut f = None;
        let mut make = Some(make);
        let _watch = FlagOnPanic(&self.failed);
        for t in (me..threads).chain(0..me) {
            while let Some(k) = self.claim(no, t, run, chunks) {
                #[cfg(test)]
                if self.fail_thread == Some(me) {
                    panic!("a failure injected in team thread {me}");
                }
                let f = f.get_or_insert_with(|| (make.take().expect("built once"))());
                f(k);
                self.completed.0.fetch_add(1, Ordering::Release);
            }
        }
    }
}

/// A pointer into one of the state's arrays that the team's threads share; each loop gives
/// every chunk to exactly one thread.
struct Shared<T>(*mut T);

// SAFETY: the team's threads write only the disjoint chunks they claim, each within one loop.
unsafe impl<T> Sync for Shared<T> {}
// SAFETY: as for `Sync`; the pointer is only copied to the team's threads.
unsafe impl<T> Send for Shared<T> {}

impl<T> Clone for Shared<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Shared<T> {}

impl<T> Shared<T> {
    fn of(v: &mut [T]) -> Shared<T> {
        Shared(v.as_mut_ptr())
    }

    /// # Safety
    /// No thread writes the pointee itself while the reference lives (the arrays it owns may be
    /// written, in chunks no reader of the loop reads).
    unsafe fn get(&self) -> &T {
        &*self.0
    }

    /// # Safety
    /// start..start + len lies in the array, and no other thread touches it until the loop
    /// ends.
    #[allow(clippy::mut_from_ref)]
    unsafe fn chunk(&self, start: usize, len: usize) -> &mut [T] {
        std::slice::from_raw_parts_mut(self.0.add(start), len)
    }
}

/// Why the team stopped.
#[derive(PartialEq)]
enum Stop {
    Done,
    Rebuild,
    /// A helper's chunk panicked (the scope passes the panic on before this is seen).
    Failed,
}

impl Dem {
    /// Completes the current step, whose first half kick, drift, wall move and neighbour list
    /// are done, and runs on until `max_steps` steps are complete or the list must be rebuilt.
    /// Returns the number of steps completed, and true when it stopped after the first half of
    /// the next one (for the caller to rebuild the list before calling again).
    pub(super) fn team_steps(&mut self, max_steps: u64) -> Result<(u64, bool)> {
        let threads = rayon::current_num_threads();
        let (n_particles, n_pairs) = (self.p.len(), self.nl.pairs.len());
        let pair_chunk = task_len(n_pairs, 4, TEAM_TASKS_PER_THREAD);
        let particle_chunk = task_len(n_particles, 8, TEAM_TASKS_PER_THREAD);
        let chunks = |kind: u64| match kind {
            PAIRS => n_pairs.div_ceil(pair_chunk),
            _ => n_particles.div_ceil(particle_chunk),
        };
        let chunk_of = |k: usize, size: usize, len: usize| (k * size, size.min(len - k * size));

        // the arrays the loops write (vel and omega in two of them), each read only in loops that
        // do not write it
        self.nl.forces = self.nl.take_forces();
        let pairs = Shared::of(&mut self.nl.pairs);
        let pair_forces = Shared::of(&mut self.nl.forces);
        let (pos, vel, omega) = (
            Shared::of(&mut self.p.pos),
            Shared::of(&mut self.p.vel),
            Shared::of(&mut self.p.omega),
        );
        let (vel_full, omega_full) = (
            Shared::of(&mut self.vel_full),
            Shared::of(&mut self.omega_full),
        );
        let (force, torque) = (Shared::of(&mut self.force), Shared::of(&mut self.torque));
        let (wall_xi, wall_fz, wall_f) = (
            Shared::of(&mut self.wall_xi),
            Shared::of(&mut self.wall_fz),
            Shared::of(&mut self.wall_f),
        );
        let this = Shared(self as *mut Dem);
        let board = Board::new(threads);
        #[cfg(test)]
        let board = Board {
            fail_thread: self.fail_team_thread,
            ..board
        };
        let moved = AtomicBool::new(false);
        let top_z = AtomicU64::new(self.top_z_m.to_bits());
        let top_v = AtomicU64::new(self.top_v_m_s.to_bits());
        let dt = self.dt_s;
        // the closures below take these by reference
        let (board, moved, top_z, top_v) = (&board, &moved, &top_z, &top_v);

        // SAFETY (every `unsafe` below): while the team runs no thread holds a `&mut Dem`; a
        // loop reads only arrays that no thread writes in it, and writes the chunks that one
        // thread claims; a thread reads the state only once it has claimed a chunk, so while
        // the loop is open and nothing else writes.
        let do_loop = |no: u64, me: usize| {
            let dem = unsafe { this.get() };
            let kind = (no - 1) % 3;
            match kind {
                PAIRS => board.work(no, me, chunks(kind), || {
                    let ctx = dem.pair_ctx();
                    move |k| {
                        let (start, len) = chunk_of(k, pair_chunk, n_pairs);
                        let (prs, fs) =
                            unsafe { (pairs.chunk(start, len), pair_forces.chunk(start, len)) };
                        run_pairs(prs, Some(fs), &ctx, None);
                    }
                }),
                GATHER => board.work(no, me, chunks(kind), || {
                    let z = f64::from_bits(top_z.load(Ordering::Relaxed));
                    let v = f64::from_bits(top_v.load(Ordering::Relaxed));
                    let ctx = dem.gather_ctx(true, z, v);
                    move |k| {
                        let (start, len) = chunk_of(k, particle_chunk, n_particles);
                        let out = unsafe {
                            GatherOut {
                                force: force.chunk(start, len),
                                torque: torque.chunk(start, len),
                                wall_xi: wall_xi.chunk(start, len),
                                wall_fz: wall_fz.chunk(start, len),
                                wall_f: wall_f.chunk(start, len),
                                vel: vel.chunk(start, len),
                                omega: omega.chunk(start, len),
                                pair_sums: None,
                            }
                        };
                        run_gather(&ctx, start, out);
                    }
                }),
                KICK => board.work(no, me, chunks(kind), || {
                    let ctx = dem.kick_ctx(n_particles);
                    move |k| {
                        let (start, len) = chunk_of(k, particle_chunk, n_particles);
                        let out = unsafe {
                            KickOut {
                                pos: pos.chunk(start, len),
                                vel: vel.chunk(start, len),
                                vel_full: vel_full.chunk(start, len),
                                omega: omega.chunk(start, len),
                                omega_full: omega_full.chunk(start, len),
                            }
                        };
                        if run_kick_drift(&ctx, start, out) {
                            moved.store(true, Ordering::Relaxed);
                        }
                    }
                }),
                _ => unreachable!("three loop kinds"),
            }
        };
        let do_loop = &do_loop;
        let helper = &|me: usize| {
            let mut seen = 0;
            loop {
                spin_until(|| board.loop_no.0.load(Ordering::Acquire) != seen);
                seen = board.loop_no.0.load(Ordering::Acquire);
                if seen == EXIT {
                    return;
                }
                do_loop(seen, me);
            }
        };
        // the leader: runs loop `no` with the helpers present and waits for its chunks; false
        // when a helper's chunk panicked (it never completes)
        let run_loop = |no: u64| {
            board.publish(no);
            do_loop(no, 0);
            let all = chunks((no - 1) % 3) as u64;
            spin_until(|| {
                board.completed.0.load(Ordering::Acquire) == all
                    || board.failed.load(Ordering::Acquire)
            });
            !board.failed.load(Ordering::Acquire)
        };
        let (mut steps, mut time_s) = (0, self.time_s);
        let mut totals: Option<WallTotals> = None;
        let (mut ledger, mut wall_before) =
            (self.wall_ledger, (self.wall_force_n, self.floor_force_n));
        let outcome = rayon::in_place_scope(|scope| {
            for me in 1..threads {
                scope.spawn(move |_| helper(me));
            }
            // the helpers go home however the leader leaves (a panic of its own included), and
            // the scope then passes on any helper's panic
            let _exit = ExitOnDrop(board);
            let mut no = 0;
            loop {
                if !(run_loop(no + 1) && run_loop(no + 2)) {
                    break Ok(Stop::Failed);
                }
                // the step's end (as in `Dem::step`)
                let dem = unsafe { this.get() };
                let z = f64::from_bits(top_z.load(Ordering::Relaxed));
                let t = dem.wall_totals(z);
                let wall_after = (t.wall_force_n, t.floor_force_n());
                if let Some(l) = &mut ledger {
                    l.add(wall_before, wall_after, dt);
                }
                wall_before = wall_after;
                let v = dem.top_speed(t.top_elastic_force_n, t.top_stiffness());
                top_v.store(v.to_bits(), Ordering::Relaxed);
                totals = Some(t);
                time_s += dt;
                steps += 1;
                if steps == max_steps {
                    break Ok(Stop::Done);
                }
                // the next step's first half
                moved.store(false, Ordering::Relaxed);
                if !run_loop(no + 3) {
                    break Ok(Stop::Failed);
                }
                no += 3;
                match next_top_z(z, v, dt, time_s) {
                    Ok(z_next) => top_z.store(z_next.to_bits(), Ordering::Relaxed),
                    Err(e) => break Err(e),
                }
                if moved.load(Ordering::Relaxed) {
                    break Ok(Stop::Rebuild);
                }
            }
        });
        self.top_z_m = f64::from_bits(top_z.load(Ordering::Relaxed));
        self.top_v_m_s = f64::from_bits(top_v.load(Ordering::Relaxed));
        self.time_s = time_s;
        self.steps += steps;
        self.wall_ledger = ledger;
        if let Some(t) = &totals {
            self.set_wall_totals(t);
        }
        let outcome = outcome?;
        assert!(outcome != Stop::Failed, "a thread of the DEM team panicked");
        Ok((steps, outcome == Stop::Rebuild))
    }
}

#[cfg(test)]
mod tests {
    use crate::dem::setup::testing::small_bed;
    use crate::dem::Dem;
    use std::time::Duration;

    /// A panic in a chunk of the leader or of a helper reaches the caller of `run`; the team
    /// neither hangs nor carries on.
    #[test]
    fn a_panic_in_any_team_thread_reaches_the_caller() {
        for thread in [0, 1] {
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || {
                let mut dem = Dem::new(small_bed(600, 0.68)).unwrap();
                dem.fail_team_thread = Some(thread);
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(2)
                    .build()
                    .unwrap();
                let run = std::panic::AssertUnwindSafe(|| pool.install(|| dem.run(300)));
                tx.send(std::panic::catch_unwind(run).is_err()).unwrap();
            });
            let panicked = rx
                .recv_timeout(Duration::from_secs(60))
                .unwrap_or_else(|_| panic!("the team hangs when thread {thread} panics"));
            assert!(
                panicked,
                "thread {thread}: the run returned instead of panicking"
            );
        }
    }
}
