//! Parameter checking, shared by every parameter section: the error type and the ranges a number
//! may lie in. A leaf: it imports nothing of the planner families, so each family's parameter
//! section can use it without an import circle through the aggregate in [`crate::config`].

/// A parameter with a value it cannot take.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("parameter `{name}`: {reason}")]
pub struct ParamError {
    pub name: String,
    pub reason: String,
}

impl ParamError {
    pub fn new(name: impl Into<String>, reason: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            reason: reason.into(),
        }
    }
}

/// The range a numeric parameter must lie in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Range {
    /// Finite and >= 0.
    NonNegative,
    /// Finite and > 0.
    Positive,
    /// In 0..=1.
    Share,
    /// In the open interval (0, 1).
    OpenUnit,
    /// Finite and greater than the bound.
    Above(f64),
    /// Within `lo..=hi`.
    Within(f64, f64),
    /// Greater than 0 and at most the bound.
    PositiveUpTo(f64),
}

impl Range {
    fn holds(self, v: f64) -> bool {
        match self {
            Range::NonNegative => v.is_finite() && v >= 0.0,
            Range::Positive => v.is_finite() && v > 0.0,
            Range::Share => (0.0..=1.0).contains(&v),
            Range::OpenUnit => v > 0.0 && v < 1.0,
            Range::Above(b) => v.is_finite() && v > b,
            Range::Within(lo, hi) => (lo..=hi).contains(&v),
            Range::PositiveUpTo(hi) => v > 0.0 && v <= hi,
        }
    }

    fn describe(self) -> String {
        match self {
            Range::NonNegative => "a finite non-negative number".into(),
            Range::Positive => "a finite positive number".into(),
            Range::Share => "within 0..=1".into(),
            Range::OpenUnit => "strictly between 0 and 1".into(),
            Range::Above(b) => format!("a finite number above {b}"),
            Range::Within(lo, hi) => format!("within {lo}..={hi}"),
            Range::PositiveUpTo(hi) => format!("positive and at most {hi}"),
        }
    }
}

/// Checks every `(name, value)` against `range`; the error names the first one out of it. The
/// one place that says what a valid number is, for every parameter section.
pub fn check(range: Range, params: &[(&str, f64)]) -> Result<(), ParamError> {
    match params.iter().find(|(_, v)| !range.holds(*v)) {
        Some((name, v)) => Err(ParamError::new(
            *name,
            // Debug: the shortest exact form (1e-300, not three hundred digits).
            format!("{v:?} is not {}", range.describe()),
        )),
        None => Ok(()),
    }
}

/// Checks that every `(name, count)` lies in `range`. Every count has an upper bound: a
/// population, an archive or a number of tries sizes tables and loops that run between two polls
/// of the deadline, so a huge value would exhaust memory or hold the plan past its time budget.
/// The bounds are generous, 10-100 x the defaults.
pub fn check_counts(
    range: std::ops::RangeInclusive<usize>,
    params: &[(&str, usize)],
) -> Result<(), ParamError> {
    match params.iter().find(|(_, v)| !range.contains(v)) {
        Some((name, v)) => Err(ParamError::new(
            *name,
            format!("{v} is not within {}..={}", range.start(), range.end()),
        )),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_error_names_the_first_parameter_out_of_range() {
        assert!(check(Range::Positive, &[("a", 1.0), ("b", 2.0)]).is_ok());
        let e = check(Range::Positive, &[("a", 1.0), ("b", 0.0), ("c", -1.0)]).unwrap_err();
        assert_eq!(e.name, "b");
        assert!(check(Range::NonNegative, &[("n", f64::NAN)]).is_err());
        assert!(check(Range::OpenUnit, &[("u", 1.0)]).is_err());
        assert!(check(Range::Above(1.0), &[("g", 1.0)]).is_err());
        assert!(check(Range::Within(1.0, 2.0), &[("w", f64::NAN)]).is_err());
        assert!(check(Range::Within(1.0, 2.0), &[("w", 2.5)]).is_err());
        assert!(check(Range::Within(1.0, 2.0), &[("w", 2.0)]).is_ok());
        assert!(check(Range::PositiveUpTo(2.0), &[("p", 0.0)]).is_err());
        assert!(check(Range::PositiveUpTo(2.0), &[("p", f64::NAN)]).is_err());
        assert!(check(Range::PositiveUpTo(2.0), &[("p", 2.0)]).is_ok());
        assert_eq!(check_counts(2..=9, &[("k", 1)]).unwrap_err().name, "k");
        assert_eq!(
            check_counts(2..=9, &[("j", 9), ("k", 10)])
                .unwrap_err()
                .name,
            "k"
        );
        assert!(check_counts(2..=9, &[("k", 2), ("j", 9)]).is_ok());
    }
}
