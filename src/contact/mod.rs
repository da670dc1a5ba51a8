//! Pair contact detection (parry style: one file per pair query) and the periodic broad phase.
