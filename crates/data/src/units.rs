//! Unit conversions between the file units of the data contract and the SI units held inside.

pub const PA_PER_KPA: f64 = 1000.0;
/// Standard atmosphere, kPa; used only to sanity-check gauge pressures in files.
pub const STANDARD_ATMOSPHERE_KPA: f64 = 101.325;
pub const M3_PER_L: f64 = 1e-3;

pub fn m_from_mm(mm: f64) -> f64 {
    mm * 1e-3
}

pub fn mm_from_m(m: f64) -> f64 {
    m * 1e3
}
