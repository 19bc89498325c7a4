//! # airsus-report: study results as HTML, figures and JSON
//!
//! Knows only result types ([`results`]) and charts ([`chart`]); no algorithm lives here.

pub mod chart;
pub mod html;
pub mod results;
pub mod thesis;
