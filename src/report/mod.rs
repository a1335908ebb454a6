//! Results as text for people and spreadsheets: CSV tables and SVG line charts (the formats),
//! and each use case's result in them (`results`); a map analysis as a PNG heat map
//! (`heatmap`).

pub mod chart;
pub mod heatmap;
pub mod results;
pub mod table;
