//! TLE texts: parsing two- and three-line sets with every error naming its line, and the checks
//! (checksum, length, line markers, fixed-column fields) that make those errors precise.

use hifitime::Epoch;

use super::chrono_to_epoch;

/// One TLE set, as read from a catalogue text.
#[derive(Clone, Debug)]
pub struct Tle {
    /// Name line of a 3-line set (a leading "0 " is stripped), `None` for 2-line sets.
    pub name: Option<String>,
    pub norad_id: u64,
    pub line1: String,
    pub line2: String,
    /// 1-based number of its line 1 in the text it was read from.
    pub line: usize,
    pub(super) elements: sgp4::Elements,
    pub(super) epoch: Epoch,
}

impl Tle {
    /// Epoch of the elements (UTC).
    pub fn epoch(&self) -> Epoch {
        self.epoch
    }
}

/// Why a TLE text was rejected; `line` is always the 1-based line number in the text.
#[derive(thiserror::Error, Debug, Clone, PartialEq)]
pub enum TleError {
    #[error("TLE line {line}: non-ASCII character at column {column}")]
    NonAscii { line: usize, column: usize },
    #[error("TLE line {line}: {length} characters, a TLE line has 69")]
    BadLength { line: usize, length: usize },
    #[error("TLE line {line}: line number marker is {found:?}, expected '{expected}'")]
    BadLineNumber {
        line: usize,
        expected: char,
        found: char,
    },
    #[error("TLE line {line}: bad checksum, expected {expected}, found {found:?}")]
    BadChecksum {
        line: usize,
        expected: u8,
        found: char,
    },
    #[error(
        "TLE line {line}: catalogue number {line2_id:?} differs from {line1_id:?} on line {line1_number}"
    )]
    CatalogueMismatch {
        line: usize,
        line1_number: usize,
        line1_id: String,
        line2_id: String,
    },
    #[error("TLE line {line}, columns {first}-{last}: {field} {text:?} does not parse")]
    BadField {
        line: usize,
        field: &'static str,
        first: usize,
        last: usize,
        text: String,
    },
    #[error("TLE line {line}, columns {first}-{last}: {field} {text:?} is outside {allowed}")]
    OutOfRange {
        line: usize,
        field: &'static str,
        first: usize,
        last: usize,
        text: String,
        allowed: &'static str,
    },
    #[error("TLE line {line}: text ends where TLE line {expected} should follow")]
    MissingLine { line: usize, expected: char },
    /// Anything the checks above let through but the `sgp4` parser refuses.
    #[error("TLE line {line}: {message}")]
    Rejected { line: usize, message: String },
}

/// Parse a text of 2-line or 3-line (name line first) TLE sets. Every error names the 1-based line number
/// and what is wrong: bad checksum (expected digit and found digit), wrong line length, wrong line number
/// marker, mismatched catalogue numbers between line 1 and line 2, a field that does not parse.
/// Blank lines and trailing white space (CR included) are ignored.
pub fn parse_tles(text: &str) -> Result<Vec<Tle>, TleError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end()))
        .filter(|(_, l)| !l.is_empty())
        .peekable();
    let mut tles = Vec::new();
    while let Some((n, text)) = lines.next() {
        let bytes = text.as_bytes();
        let looks_like_line1 = text.starts_with("1 ") || (bytes.len() == 69 && bytes[0] == b'1');
        let (name, first) = if looks_like_line1 {
            (None, (n, text))
        } else if text.starts_with("2 ") {
            return Err(TleError::BadLineNumber {
                line: n,
                expected: '1',
                found: '2',
            });
        } else if text.len() == 69
            && text.is_ascii()
            && lines.peek().is_some_and(|(_, l)| l.starts_with("2 "))
        {
            // A 69-character line followed by a line 2 is a line 1 with a damaged marker, not a name.
            let found = bytes[0] as char;
            return Err(TleError::BadLineNumber {
                line: n,
                expected: '1',
                found,
            });
        } else {
            let name = text.trim();
            let name = name.strip_prefix("0 ").unwrap_or(name).trim().to_string();
            let next = lines.next().ok_or(TleError::MissingLine {
                line: n,
                expected: '1',
            })?;
            (Some(name), next)
        };
        let second = lines.next().ok_or(TleError::MissingLine {
            line: first.0,
            expected: '2',
        })?;
        tles.push(parse_one(name, first, second)?);
    }
    Ok(tles)
}

/// TLE checksum: sum of the digits of the first 68 columns, '-' counting 1, modulo 10.
fn checksum(line: &[u8]) -> u8 {
    let sum: u32 = line
        .iter()
        .take(68)
        .map(|&c| match c {
            b'0'..=b'9' => u32::from(c - b'0'),
            b'-' => 1,
            _ => 0,
        })
        .sum();
    (sum % 10) as u8
}

/// Structural checks of one line (ASCII, length, marker, checksum), before any field is read.
fn check_line(n: usize, text: &str, marker: u8) -> Result<(), TleError> {
    if let Some((i, _)) = text.char_indices().find(|(_, c)| !c.is_ascii()) {
        let column = text[..i].chars().count() + 1;
        return Err(TleError::NonAscii { line: n, column });
    }
    let b = text.as_bytes();
    if b.len() != 69 {
        return Err(TleError::BadLength {
            line: n,
            length: b.len(),
        });
    }
    if b[0] != marker {
        return Err(TleError::BadLineNumber {
            line: n,
            expected: marker as char,
            found: b[0] as char,
        });
    }
    let expected = checksum(b);
    if b[68] != b'0' + expected {
        return Err(TleError::BadChecksum {
            line: n,
            expected,
            found: b[68] as char,
        });
    }
    Ok(())
}

/// How a fixed-column field is read; mirrors what `sgp4::Elements::from_tle` accepts, so that a bad
/// field is reported by name and columns rather than by the crate's generic message.
#[derive(Clone, Copy)]
enum Kind {
    Space,
    Alpha5,
    Classification,
    /// Two digits, no blanks (epoch year, exponents are `Exponent`).
    TwoDigits,
    Exponent,
    Float,
    /// Decimal point assumed before the digits ("12345" is 0.12345), optional sign.
    Assumed,
    Unsigned,
}

const LINE1_FIELDS: &[(usize, usize, &str, Kind)] = &[
    (1, 2, "separator", Kind::Space),
    (2, 7, "catalogue number", Kind::Alpha5),
    (7, 8, "classification", Kind::Classification),
    (8, 9, "separator", Kind::Space),
    (17, 18, "separator", Kind::Space),
    (18, 20, "epoch year", Kind::TwoDigits),
    (20, 32, "epoch day", Kind::Float),
    (32, 33, "separator", Kind::Space),
    (33, 43, "first derivative of mean motion", Kind::Float),
    (43, 44, "separator", Kind::Space),
    (44, 50, "second derivative of mean motion", Kind::Assumed),
    (50, 52, "second derivative exponent", Kind::Exponent),
    (52, 53, "separator", Kind::Space),
    (53, 59, "B* drag term", Kind::Assumed),
    (59, 61, "B* exponent", Kind::Exponent),
    (61, 62, "separator", Kind::Space),
    (62, 63, "ephemeris type", Kind::Unsigned),
    (63, 64, "separator", Kind::Space),
    (64, 68, "element set number", Kind::Unsigned),
];

const LINE2_FIELDS: &[(usize, usize, &str, Kind)] = &[
    (1, 2, "separator", Kind::Space),
    (2, 7, "catalogue number", Kind::Alpha5),
    (7, 8, "separator", Kind::Space),
    (8, 16, "inclination", Kind::Float),
    (16, 17, "separator", Kind::Space),
    (17, 25, "right ascension of the ascending node", Kind::Float),
    (25, 26, "separator", Kind::Space),
    (26, 33, "eccentricity", Kind::Assumed),
    (33, 34, "separator", Kind::Space),
    (34, 42, "argument of perigee", Kind::Float),
    (42, 43, "separator", Kind::Space),
    (43, 51, "mean anomaly", Kind::Float),
    (51, 52, "separator", Kind::Space),
    (52, 63, "mean motion", Kind::Float),
    (63, 68, "revolution number", Kind::Unsigned),
];

/// The physical ranges of line 2's elements (columns as in `LINE2_FIELDS`): values the fixed
/// columns let through but no orbit has. A mean motion above 17.1 revolutions a day is an orbit
/// below the Earth's surface (84.5 minutes).
const LINE2_RANGES: &[(usize, usize, &str, f64, f64, &str)] = &[
    (8, 16, "inclination", 0.0, 180.0, "[0, 180] degrees"),
    (
        17,
        25,
        "right ascension of the ascending node",
        0.0,
        360.0,
        "[0, 360] degrees",
    ),
    // Seven digits after an assumed point: below 1 whenever it is not negative.
    (26, 33, "eccentricity", 0.0, 1.0, "[0, 1)"),
    (
        34,
        42,
        "argument of perigee",
        0.0,
        360.0,
        "[0, 360] degrees",
    ),
    (43, 51, "mean anomaly", 0.0, 360.0, "[0, 360] degrees"),
    (
        52,
        63,
        "mean motion",
        f64::MIN_POSITIVE,
        17.1,
        "(0, 17.1] revolutions a day",
    ),
];

/// Refuse an element of line 2 outside its physical range (`LINE2_RANGES`).
fn check_ranges(n: usize, text: &str) -> Result<(), TleError> {
    for &(start, end, field, lo, hi, allowed) in LINE2_RANGES {
        let s = &text[start..end];
        let t = s.trim();
        // The eccentricity's decimal point is assumed.
        let value = if field == "eccentricity" {
            format!(".{}", t.trim_start_matches(['-', '+']))
                .parse::<f64>()
                .map(|x| if t.starts_with('-') { -x } else { x })
        } else {
            t.parse::<f64>()
        };
        if !value.is_ok_and(|x| (lo..=hi).contains(&x)) {
            return Err(TleError::OutOfRange {
                line: n,
                field,
                first: start + 1,
                last: end,
                text: s.to_string(),
                allowed,
            });
        }
    }
    Ok(())
}

fn field_ok(s: &str, kind: Kind) -> bool {
    let t = s.trim_start();
    let finite = |x: &str| x.parse::<f64>().is_ok_and(f64::is_finite);
    match kind {
        Kind::Space => s == " ",
        Kind::Alpha5 => {
            let b = t.as_bytes();
            if b.len() == 5 && b[0].is_ascii_uppercase() {
                !matches!(b[0], b'I' | b'O') && b[1..].iter().all(u8::is_ascii_digit)
            } else {
                !t.is_empty() && t.bytes().all(|c| c.is_ascii_digit())
            }
        }
        Kind::Classification => matches!(s, "U" | "C" | "S"),
        Kind::TwoDigits => s.len() == 2 && s.bytes().all(|c| c.is_ascii_digit()),
        Kind::Exponent => s.parse::<i8>().is_ok(),
        Kind::Float => finite(t),
        Kind::Assumed => {
            let digits = t.strip_prefix(['-', '+']).unwrap_or(t);
            !digits.is_empty() && finite(&format!(".{digits}"))
        }
        Kind::Unsigned => t.parse::<u64>().is_ok(),
    }
}

fn check_fields(
    n: usize,
    text: &str,
    fields: &[(usize, usize, &'static str, Kind)],
) -> Result<(), TleError> {
    for &(start, end, field, kind) in fields {
        let s = &text[start..end];
        if !field_ok(s, kind) {
            return Err(TleError::BadField {
                line: n,
                field,
                first: start + 1,
                last: end,
                text: s.to_string(),
            });
        }
    }
    Ok(())
}

fn parse_one(
    name: Option<String>,
    (n1, l1): (usize, &str),
    (n2, l2): (usize, &str),
) -> Result<Tle, TleError> {
    check_line(n1, l1, b'1')?;
    check_line(n2, l2, b'2')?;
    let (id1, id2) = (l1[2..7].trim(), l2[2..7].trim());
    if id1 != id2 {
        return Err(TleError::CatalogueMismatch {
            line: n2,
            line1_number: n1,
            line1_id: id1.to_string(),
            line2_id: id2.to_string(),
        });
    }
    check_fields(n1, l1, LINE1_FIELDS)?;
    if !l1[9..17].trim().is_empty() && !field_ok(&l1[9..11], Kind::TwoDigits) {
        let text = l1[9..11].to_string();
        return Err(TleError::BadField {
            line: n1,
            field: "international designator year",
            first: 10,
            last: 11,
            text,
        });
    }
    // The epoch day must fall inside its year (day 1.0 is 1 January 00:00).
    let year = 1900 + l1[18..20].parse::<i32>().unwrap_or(0);
    let year = if year < 1957 { year + 100 } else { year };
    let leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
    let day: f64 = l1[20..32].trim().parse().unwrap_or(f64::NAN);
    if !(1.0..if leap { 367.0 } else { 366.0 }).contains(&day) {
        return Err(TleError::BadField {
            line: n1,
            field: "epoch day",
            first: 21,
            last: 32,
            text: l1[20..32].to_string(),
        });
    }
    check_fields(n2, l2, LINE2_FIELDS)?;
    check_ranges(n2, l2)?;
    let elements =
        sgp4::Elements::from_tle(name.clone(), l1.as_bytes(), l2.as_bytes()).map_err(|e| {
            let message = e.to_string();
            let line = if message.contains("line 2") { n2 } else { n1 };
            TleError::Rejected { line, message }
        })?;
    let epoch = chrono_to_epoch(&elements.datetime).ok_or_else(|| TleError::BadField {
        line: n1,
        field: "epoch",
        first: 19,
        last: 32,
        text: l1[18..32].to_string(),
    })?;
    Ok(Tle {
        name,
        norad_id: elements.norad_id,
        line1: l1.to_string(),
        line2: l2.to_string(),
        line: n1,
        elements,
        epoch,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::orbit::{Propagator, Regime};
    use crate::testing::{catalog, catalog_text};
    use hifitime::Unit;

    /// Line with its checksum recomputed, to build TLEs that fail only where a test wants.
    fn with_checksum(line: &str) -> String {
        format!("{}{}", &line[..68], checksum(line.as_bytes()))
    }

    #[test]
    fn parses_catalogue_and_regimes() {
        let tles = catalog();
        let ids: Vec<u64> = tles.iter().map(|t| t.norad_id).collect();
        assert_eq!(ids, [37476, 40386, 40989, 41335, 37216]);
        assert_eq!(tles[3].name.as_deref(), Some("SENTINEL 3A"));
        assert_eq!(tles[0].line1.len(), 69);
        // 2022 day 22.47100279 = 2022-01-22T11:18:14.641056 UTC
        let expected = Epoch::from_gregorian_utc(2022, 1, 22, 11, 18, 14, 641_056_000);
        assert!((tles[3].epoch() - expected).abs() < 1.0 * Unit::Microsecond);
        for tle in &tles {
            let regime = Propagator::from_tle(tle).unwrap().regime();
            let deep = matches!(tle.norad_id, 40386 | 40989);
            assert_eq!(
                regime,
                if deep {
                    Regime::DeepSpace
                } else {
                    Regime::NearEarth
                },
                "{}",
                tle.norad_id
            );
        }
    }

    #[test]
    fn elements_outside_their_physical_ranges_are_refused_by_line_and_field() {
        let text = catalog_text();
        let lines: Vec<String> = text.lines().map(str::to_string).collect();
        // FENGYUN 1C DEB's line 2 is the file's line 3.
        let l2 = &lines[2];
        for (first, last, value, field) in [
            (9, 16, "200.0000", "inclination"),
            (18, 25, "400.0000", "right ascension of the ascending node"),
            (35, 42, "361.0000", "argument of perigee"),
            (44, 51, "999.9999", "mean anomaly"),
            (53, 63, " 0.00000000", "mean motion"),
            (53, 63, "25.00000000", "mean motion"),
        ] {
            let mut bad = lines.clone();
            let mut line = l2.clone();
            let width = last - first + 1;
            let value = format!("{value:>width$}");
            line.replace_range(first - 1..last, &value[value.len() - width..]);
            bad[2] = with_checksum(&line);
            let err = parse_tles(&bad.join("\n")).unwrap_err();
            assert!(
                matches!(&err, TleError::OutOfRange { line: 3, field: f, .. } if *f == field),
                "{value}: {err}"
            );
        }
        // The catalogue's own orbits are all within range.
        assert_eq!(parse_tles(&text).unwrap().len(), 5);
    }

    #[test]
    fn two_line_sets_and_name_prefix_parse() {
        let text = catalog_text();
        let lines: Vec<&str> = text.lines().collect();
        let two = format!("{}\r\n{}\r\n\r\n", lines[1], lines[2]);
        let tles = parse_tles(&two).unwrap();
        assert_eq!(
            (tles.len(), tles[0].name.clone(), tles[0].norad_id),
            (1, None, 37476)
        );
        let three = format!("0 {}\n{}\n{}\n", lines[0], lines[1], lines[2]);
        assert_eq!(
            parse_tles(&three).unwrap()[0].name.as_deref(),
            Some("FENGYUN 1C DEB")
        );
        assert!(parse_tles("").unwrap().is_empty());
        assert!(parse_tles(" \n\n").unwrap().is_empty());
    }

    #[test]
    fn tle_errors_name_the_line() {
        let text = catalog_text();
        let lines: Vec<String> = text.lines().map(str::to_string).collect();
        let join = |l: &[String]| l.join("\n");
        // The error of the catalogue with its line `k` (0-based) edited.
        let error_after = |k: usize, edit: &dyn Fn(&mut String)| {
            let mut edited = lines.clone();
            edit(&mut edited[k]);
            parse_tles(&join(&edited)).unwrap_err()
        };
        // The error of the catalogue with `from` replaced by `to` on line `k`, its checksum
        // recomputed (so that the field, not the checksum, is what is wrong).
        let replaced = |k: usize, from: &str, to: &str| {
            error_after(k, &|l| *l = with_checksum(&l.replacen(from, to, 1)))
        };

        // 40386 line 1, true checksum 6.
        let err = error_after(4, &|l| l.replace_range(68..69, "7"));
        assert_eq!(
            err,
            TleError::BadChecksum {
                line: 5,
                expected: 6,
                found: '7'
            }
        );
        assert!(err.to_string().contains("line 5"), "{err}");

        assert_eq!(
            error_after(8, &|l| l.truncate(60)),
            TleError::BadLength {
                line: 9,
                length: 60
            }
        );

        assert_eq!(
            replaced(11, "41335", "41336"),
            TleError::CatalogueMismatch {
                line: 12,
                line1_number: 11,
                line1_id: "41335".into(),
                line2_id: "41336".into(),
            }
        );

        assert_eq!(
            error_after(2, &|l| *l = with_checksum(&format!("3{}", &l[1..]))),
            TleError::BadLineNumber {
                line: 3,
                expected: '2',
                found: '3'
            }
        );

        assert_eq!(
            replaced(5, "50.6833", "50.6x33"),
            TleError::BadField {
                line: 6,
                field: "inclination",
                first: 9,
                last: 16,
                text: " 50.6x33".into(),
            }
        );

        assert_eq!(
            error_after(13, &|l| l.replace_range(20..21, "é")),
            TleError::NonAscii {
                line: 14,
                column: 21
            }
        );

        assert_eq!(
            parse_tles(&join(&lines[..14])).unwrap_err(),
            TleError::MissingLine {
                line: 14,
                expected: '2'
            }
        );
        assert_eq!(
            parse_tles("JUST A NAME").unwrap_err(),
            TleError::MissingLine {
                line: 1,
                expected: '1'
            }
        );
    }

    #[test]
    fn damaged_texts_never_panic() {
        let text = catalog_text();
        for end in 0..=text.len() {
            if text.is_char_boundary(end) {
                let _ = parse_tles(&text[..end]);
            }
        }
        let replacements = ["X", "é", " ", "-", "+", ".", "9", "\u{0}", "€", "\n", "inf"];
        let t = Epoch::from_gregorian_utc_at_midnight(2022, 6, 1);
        for i in 0..text.len() {
            for rep in replacements {
                let mut damaged = text.clone();
                damaged.replace_range(i..i + 1, rep);
                if let Ok(tles) = parse_tles(&damaged) {
                    for tle in &tles {
                        if let Ok(prop) = Propagator::from_tle(tle)
                            && let Ok(r) = prop.position_teme_km(t)
                        {
                            assert!(r.iter().all(|x| x.is_finite()));
                        }
                    }
                }
            }
        }
    }
}
