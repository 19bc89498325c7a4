//! The registry's unit strings (`"Pa s/mol"`, `"m3/(s Pa)"`, `"1/(100 kPa)"`, `"kg m²"`) as FMI
//! `<BaseUnit>` elements: exponents of the SI base units and a factor (FMI 2.0 §2.2.2,
//! `fmi2Unit.xsd`: `kg m s A K mol cd rad`, `factor`, `offset`).
//!
//! Grammar: `product [ "/" product ]`, a product being space-separated factors, optionally in
//! parentheses; a factor is a positive number or a symbol with an optional exponent (`m²`,
//! `m³`, `m3`, `m^2`). A unit outside this grammar gets a `<Unit>` without `<BaseUnit>`, which
//! FMI allows.

/// Exponents of `kg, m, s, A, K, mol, cd, rad` (the order of `fmi2Unit.xsd`) and a factor:
/// `value_in_base_units = factor * value`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseUnit {
    pub exponents: [i32; 8],
    pub factor: f64,
}

const BASE_NAMES: [&str; 8] = ["kg", "m", "s", "A", "K", "mol", "cd", "rad"];

impl BaseUnit {
    const ONE: Self = Self {
        exponents: [0; 8],
        factor: 1.0,
    };

    const fn base(index: usize, factor: f64) -> Self {
        let mut exponents = [0; 8];
        exponents[index] = 1;
        Self { exponents, factor }
    }

    const fn derived(exponents: [i32; 8], factor: f64) -> Self {
        Self { exponents, factor }
    }

    fn times(self, other: Self) -> Self {
        let mut exponents = self.exponents;
        for (e, o) in exponents.iter_mut().zip(other.exponents) {
            *e += o;
        }
        Self {
            exponents,
            factor: self.factor * other.factor,
        }
    }

    /// `self^n` by repeated multiplication (no `powi`: the exporter and the library must format
    /// bit-identical factors, and `powi` may be folded differently at compile time).
    fn power(self, n: i32) -> Self {
        let mut factor = 1.0;
        for _ in 0..n.unsigned_abs() {
            factor *= self.factor;
        }
        if n < 0 {
            factor = 1.0 / factor;
        }
        Self {
            exponents: self.exponents.map(|e| e * n),
            factor,
        }
    }

    /// The `<BaseUnit …/>` element (zero exponents and a unit factor left out).
    pub fn to_xml(&self) -> String {
        let mut s = String::from("<BaseUnit");
        for (name, e) in BASE_NAMES.iter().zip(self.exponents) {
            if e != 0 {
                s.push_str(&format!(" {name}=\"{e}\""));
            }
        }
        if self.factor != 1.0 {
            s.push_str(&format!(" factor=\"{:?}\"", self.factor));
        }
        s.push_str("/>");
        s
    }
}

/// The base-unit form of `text`, `None` outside the grammar of the module docs.
pub fn parse_unit(text: &str) -> Option<BaseUnit> {
    let (numerator, denominator) = match text.split_once('/') {
        Some((n, d)) => (n, Some(d)),
        None => (text, None),
    };
    let mut unit = parse_product(numerator)?;
    if let Some(d) = denominator {
        if d.contains('/') {
            return None;
        }
        unit = unit.times(parse_product(d)?.power(-1));
    }
    unit.factor.is_finite().then_some(unit)
}

fn parse_product(text: &str) -> Option<BaseUnit> {
    let text = text.trim();
    let inner = match text.strip_prefix('(') {
        Some(rest) => rest.strip_suffix(')')?,
        None => text,
    };
    if inner.contains(['(', ')']) {
        return None;
    }
    let mut unit = BaseUnit::ONE;
    let mut any = false;
    for token in inner.split_whitespace() {
        unit = unit.times(parse_factor(token)?);
        any = true;
    }
    any.then_some(unit)
}

fn parse_factor(token: &str) -> Option<BaseUnit> {
    if let Ok(number) = token.parse::<f64>() {
        return (number.is_finite() && number > 0.0).then_some(BaseUnit {
            exponents: [0; 8],
            factor: number,
        });
    }
    let (symbol, exponent) = split_exponent(token)?;
    Some(symbol_unit(symbol)?.power(exponent))
}

fn split_exponent(token: &str) -> Option<(&str, i32)> {
    if let Some(symbol) = token.strip_suffix('²') {
        return Some((symbol, 2));
    }
    if let Some(symbol) = token.strip_suffix('³') {
        return Some((symbol, 3));
    }
    if let Some((symbol, exponent)) = token.split_once('^') {
        return Some((symbol, exponent.parse().ok()?));
    }
    let symbol = token.trim_end_matches(|c: char| c.is_ascii_digit());
    if symbol.is_empty() {
        return None;
    }
    if symbol.len() == token.len() {
        return Some((token, 1));
    }
    Some((symbol, token[symbol.len()..].parse().ok()?))
}

fn symbol_unit(symbol: &str) -> Option<BaseUnit> {
    // index: kg 0, m 1, s 2, A 3, K 4, mol 5, cd 6, rad 7
    let unit = match symbol {
        "kg" => BaseUnit::base(0, 1.0),
        "g" => BaseUnit::base(0, 1e-3),
        "m" => BaseUnit::base(1, 1.0),
        "mm" => BaseUnit::base(1, 1e-3),
        "s" => BaseUnit::base(2, 1.0),
        "A" => BaseUnit::base(3, 1.0),
        "K" => BaseUnit::base(4, 1.0),
        "mol" => BaseUnit::base(5, 1.0),
        "cd" => BaseUnit::base(6, 1.0),
        "rad" => BaseUnit::base(7, 1.0),
        "N" => BaseUnit::derived([1, 1, -2, 0, 0, 0, 0, 0], 1.0),
        "Pa" => BaseUnit::derived([1, -1, -2, 0, 0, 0, 0, 0], 1.0),
        "kPa" => BaseUnit::derived([1, -1, -2, 0, 0, 0, 0, 0], 1e3),
        "J" => BaseUnit::derived([1, 2, -2, 0, 0, 0, 0, 0], 1.0),
        "W" => BaseUnit::derived([1, 2, -3, 0, 0, 0, 0, 0], 1.0),
        "Hz" => BaseUnit::derived([0, 0, -1, 0, 0, 0, 0, 0], 1.0),
        "l" | "L" => BaseUnit::derived([0, 3, 0, 0, 0, 0, 0, 0], 1e-3),
        _ => return None,
    };
    Some(unit)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exps(text: &str) -> [i32; 8] {
        parse_unit(text)
            .unwrap_or_else(|| panic!("{text}"))
            .exponents
    }

    #[test]
    fn every_registry_unit_parses() {
        assert_eq!(exps("kg"), [1, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(exps("m²"), [0, 2, 0, 0, 0, 0, 0, 0]);
        assert_eq!(exps("1/m²"), [0, -2, 0, 0, 0, 0, 0, 0]);
        assert_eq!(exps("1"), [0; 8]);
        assert_eq!(exps("kg m²"), [1, 2, 0, 0, 0, 0, 0, 0]);
        assert_eq!(exps("N s/m"), [1, 0, -1, 0, 0, 0, 0, 0]);
        assert_eq!(exps("N/m"), [1, 0, -2, 0, 0, 0, 0, 0]);
        assert_eq!(exps("m/N"), [-1, 0, 2, 0, 0, 0, 0, 0]);
        assert_eq!(exps("Pa s/mol"), [1, -1, -1, 0, 0, -1, 0, 0]);
        assert_eq!(exps("m3/(s Pa)"), [-1, 4, 1, 0, 0, 0, 0, 0]);
        let per_bar = parse_unit("1/(100 kPa)").unwrap();
        assert_eq!(per_bar.exponents, [-1, 1, 2, 0, 0, 0, 0, 0]);
        assert!((per_bar.factor - 1e-5).abs() < 1e-20);
        let kpa = parse_unit("kPa").unwrap();
        assert_eq!(
            kpa.to_xml(),
            "<BaseUnit kg=\"1\" m=\"-1\" s=\"-2\" factor=\"1000.0\"/>"
        );
        assert_eq!(
            parse_unit("mm").unwrap().to_xml(),
            "<BaseUnit m=\"1\" factor=\"0.001\"/>"
        );
        assert_eq!(parse_unit("1").unwrap().to_xml(), "<BaseUnit/>");
    }

    #[test]
    fn units_outside_the_grammar_are_none() {
        for text in ["", "furlong", "m/s/s", "(m", "kg)", "m^x", "0 m", "-1 m"] {
            assert!(parse_unit(text).is_none(), "{text}");
        }
    }
}
