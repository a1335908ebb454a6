//! Results as text for people and spreadsheets: CSV tables and SVG line charts (the formats),
//! and each use case's result in them (`results`).

pub mod chart;
pub mod results;
pub mod table;
