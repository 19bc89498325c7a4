//! airsus identification.
//!
//! * [`linear`]: linear black-box models (ARX, ARMAX, OE, BJ), multi-input single-output, with
//!   parameter uncertainty, order selection, state-space conversion and zero-order-hold
//!   `c2d`/`d2c` (thesis §3.2–3.4, §5.2.4–5.2.5).

pub mod linear;
