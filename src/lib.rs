//! Preston: dwell-time planning for dual-rotor small-tool polishing of rotationally symmetric
//! optics. See `ARCHITECTURE.md` for the map; [`physics`] is the pure numerical core.

pub mod physics;
