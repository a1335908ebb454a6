//! Results as text for people and spreadsheets: CSV tables and SVG line charts. Formats only:
//! what goes into a table or a chart is the caller's.

pub mod chart;
pub mod table;
