//! Real star catalogs: Gaia archive, VizieR or plain CSV exports, moved to the observation epoch
//! with Eq. 8 of the paper (linear in RA/Dec, RA rate = `pmra / cos dec`).

use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};

use super::{Star, chord2, cone, normalize_ra, sort_stars};
use crate::radec_unit;

/// Milliarcseconds per degree: the "conversion factor" of Eq. 8.
const MAS_PER_DEG: f64 = 3.6e6;

#[derive(Clone, Copy, Debug)]
struct CatalogStar {
    ra: f64,
    dec: f64,
    pmra: f64,
    pmdec: f64,
    mag: f64,
}

/// A real catalog read from CSV, as the Gaia archive (ra, dec, pmra, pmdec, phot_g_mean_mag) or
/// VizieR (RA_ICRS, DE_ICRS, pmRA, pmDE, Gmag) export it, or plain (ra, dec, pmra, pmdec, mag);
/// case-insensitive headers; empty proper motions count as 0; `#` comment lines allowed.
///
/// Positions in degrees at the catalog epoch, `pmra` = mu_alpha* = mu_alpha cos dec and `pmdec`
/// in mas/yr. Proper-motion columns may be absent (all zero); other columns are ignored.
#[derive(Clone, Debug)]
pub struct StarCatalog {
    epoch_jyear: f64,
    /// Sorted by catalog declination.
    stars: Vec<CatalogStar>,
    max_abs_pmdec: f64,
}

/// Errors reading a star catalog. Every error names the file (`<reader>` when read from a
/// reader), and where it applies the 1-based line and the column.
#[derive(thiserror::Error, Debug)]
pub enum CatalogError {
    #[error("cannot read star catalog {}: {source}", .path.display())]
    Open {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot read star catalog {}: {source}", FileLabel(.file))]
    Read {
        file: Option<PathBuf>,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: no header line", FileLabel(.file))]
    NoHeader { file: Option<PathBuf> },
    #[error("{}:{line}: header has no {field} column (accepted, any case: {accepted})", FileLabel(.file))]
    MissingColumn {
        file: Option<PathBuf>,
        line: u64,
        field: &'static str,
        accepted: String,
    },
    #[error("{}:{line}: columns `{first}` and `{second}` both name the {field}", FileLabel(.file))]
    AmbiguousColumn {
        file: Option<PathBuf>,
        line: u64,
        field: &'static str,
        first: String,
        second: String,
    },
    #[error("{}:{line}: column `{column}`: {problem} (value {value:?})", FileLabel(.file))]
    BadValue {
        file: Option<PathBuf>,
        line: u64,
        column: String,
        value: String,
        problem: &'static str,
    },
    #[error("{}:{line}: malformed CSV: {message}", FileLabel(.file))]
    Malformed {
        file: Option<PathBuf>,
        line: u64,
        message: String,
    },
    #[error("{}: catalog epoch {epoch} is not a finite Julian year", FileLabel(.file))]
    BadEpoch { file: Option<PathBuf>, epoch: f64 },
}

struct FileLabel<'a>(&'a Option<PathBuf>);

impl fmt::Display for FileLabel<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(p) => write!(f, "{}", p.display()),
            None => f.write_str("<reader>"),
        }
    }
}

/// The input without comment (`#`) and blank lines, `\n`-terminated, with the original 1-based
/// line number of every kept line. (The csv crate miscounts lines after comments and CRLF.)
struct FilteredText {
    bytes: Vec<u8>,
    starts: Vec<usize>,
    lines: Vec<u64>,
}

impl FilteredText {
    fn new(raw: &[u8]) -> Self {
        let raw = raw.strip_prefix(b"\xef\xbb\xbf").unwrap_or(raw);
        let mut t = FilteredText {
            bytes: Vec::with_capacity(raw.len()),
            starts: Vec::new(),
            lines: Vec::new(),
        };
        for (i, line) in raw.split(|&c| c == b'\n').enumerate() {
            let line = line.strip_suffix(b"\r").unwrap_or(line);
            match line.iter().position(|c| !c.is_ascii_whitespace()) {
                None => continue,
                Some(k) if line[k] == b'#' => continue,
                Some(_) => {}
            }
            t.starts.push(t.bytes.len());
            t.lines.push(i as u64 + 1);
            t.bytes.extend_from_slice(line);
            t.bytes.push(b'\n');
        }
        t
    }

    /// Original line of the record whose csv position is `byte` (that position may point at the
    /// previous line's terminator).
    fn line_of(&self, byte: u64) -> u64 {
        let mut b = byte as usize;
        while b < self.bytes.len() && self.bytes[b] == b'\n' {
            b += 1;
        }
        let k = self.starts.partition_point(|&s| s <= b).saturating_sub(1);
        self.lines.get(k).copied().unwrap_or(0)
    }
}

/// Accepted header names (lower case) per field, and whether the field is required.
const COLUMNS: [(&str, &[&str], bool); 5] = [
    ("right ascension", &["ra", "ra_icrs"], true),
    ("declination", &["dec", "de_icrs"], true),
    ("RA proper motion", &["pmra"], false),
    ("Dec proper motion", &["pmdec", "pmde"], false),
    ("magnitude", &["phot_g_mean_mag", "gmag", "mag"], true),
];

impl StarCatalog {
    pub fn from_csv_path(path: &Path, epoch_jyear: f64) -> Result<Self, CatalogError> {
        let file = std::fs::File::open(path).map_err(|source| CatalogError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        Self::read(
            std::io::BufReader::new(file),
            epoch_jyear,
            Some(path.to_path_buf()),
        )
    }

    pub fn from_reader<R: Read>(r: R, epoch_jyear: f64) -> Result<Self, CatalogError> {
        Self::read(r, epoch_jyear, None)
    }

    fn read<R: Read>(
        mut r: R,
        epoch_jyear: f64,
        file: Option<PathBuf>,
    ) -> Result<Self, CatalogError> {
        if !epoch_jyear.is_finite() {
            return Err(CatalogError::BadEpoch {
                file,
                epoch: epoch_jyear,
            });
        }
        let mut raw = Vec::new();
        r.read_to_end(&mut raw)
            .map_err(|source| CatalogError::Read {
                file: file.clone(),
                source,
            })?;
        let text = FilteredText::new(&raw);
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .trim(csv::Trim::All)
            .from_reader(&text.bytes[..]);
        let mut records = reader.records();
        let malformed = |e: csv::Error, file: &Option<PathBuf>| {
            let line = e.position().map_or(0, |p| text.line_of(p.byte()));
            let message = match e.kind() {
                csv::ErrorKind::UnequalLengths {
                    expected_len, len, ..
                } => {
                    format!("{len} fields where the header has {expected_len}")
                }
                csv::ErrorKind::Utf8 { err, .. } => {
                    format!("field {}: invalid UTF-8", err.field() + 1)
                }
                _ => e.to_string(),
            };
            CatalogError::Malformed {
                file: file.clone(),
                line,
                message,
            }
        };
        let header = match records.next() {
            None => return Err(CatalogError::NoHeader { file }),
            Some(Err(e)) => return Err(malformed(e, &file)),
            Some(Ok(h)) => h,
        };
        let line_of =
            |rec: &csv::StringRecord| rec.position().map_or(0, |p| text.line_of(p.byte()));
        let header_line = line_of(&header);
        let names: Vec<String> = header.iter().map(str::to_string).collect();
        let mut index: [Option<usize>; 5] = [None; 5];
        for (f, (field, aliases, required)) in COLUMNS.iter().enumerate() {
            for (i, name) in names.iter().enumerate() {
                if aliases.iter().any(|a| a.eq_ignore_ascii_case(name)) {
                    if let Some(prev) = index[f] {
                        return Err(CatalogError::AmbiguousColumn {
                            file,
                            line: header_line,
                            field,
                            first: names[prev].clone(),
                            second: name.clone(),
                        });
                    }
                    index[f] = Some(i);
                }
            }
            if *required && index[f].is_none() {
                return Err(CatalogError::MissingColumn {
                    file,
                    line: header_line,
                    field,
                    accepted: aliases.join(", "),
                });
            }
        }

        let mut stars = Vec::new();
        for rec in records {
            let rec = rec.map_err(|e| malformed(e, &file))?;
            let line = line_of(&rec);
            let mut values = [0.0f64; 5];
            for (f, idx) in index.iter().enumerate() {
                let Some(i) = *idx else { continue };
                let text = rec.get(i).unwrap_or("");
                let bad = |problem: &'static str| CatalogError::BadValue {
                    file: file.clone(),
                    line,
                    column: names[i].clone(),
                    value: text.to_string(),
                    problem,
                };
                let is_pm = f == 2 || f == 3;
                if text.is_empty() {
                    if is_pm {
                        continue;
                    }
                    return Err(bad("empty value"));
                }
                let v: f64 = text.parse().map_err(|_| bad("not a number"))?;
                if !v.is_finite() {
                    return Err(bad("not finite"));
                }
                let in_range = match f {
                    0 => (0.0..=360.0).contains(&v),
                    1 => (-90.0..=90.0).contains(&v),
                    _ => true,
                };
                if !in_range {
                    return Err(bad(if f == 0 {
                        "out of range [0, 360] deg"
                    } else {
                        "out of range [-90, 90] deg"
                    }));
                }
                values[f] = v;
            }
            let [ra, dec, pmra, pmdec, mag] = values;
            stars.push(CatalogStar {
                ra: normalize_ra(ra),
                dec,
                pmra,
                pmdec,
                mag,
            });
        }
        stars.sort_by(|a, b| a.dec.total_cmp(&b.dec));
        let max_abs_pmdec = stars.iter().fold(0.0f64, |m, s| m.max(s.pmdec.abs()));
        Ok(Self {
            epoch_jyear,
            stars,
            max_abs_pmdec,
        })
    }

    pub fn len(&self) -> usize {
        self.stars.len()
    }

    pub fn is_empty(&self) -> bool {
        self.stars.is_empty()
    }

    /// Catalog epoch (Julian year) the positions refer to.
    pub fn epoch_jyear(&self) -> f64 {
        self.epoch_jyear
    }

    /// Stars in the cone after proper motion to `at_jyear` (Eq. 8: RA rate divided by cos dec,
    /// pmra given as mu_alpha* in mas/yr), same order rule.
    pub fn stars_in_cone(
        &self,
        ra_deg: f64,
        dec_deg: f64,
        radius_deg: f64,
        mag_max: f64,
        at_jyear: f64,
    ) -> Vec<Star> {
        let mut out = Vec::new();
        let Some((centre, max_chord2)) = cone(ra_deg, dec_deg, radius_deg, mag_max) else {
            return out;
        };
        if !at_jyear.is_finite() {
            return out;
        }
        let dt = at_jyear - self.epoch_jyear;
        // Eq. 8 moves dec by at most max|pmdec| dt (a pole crossing only folds it back), so only
        // stars whose catalog dec is that close to the cone's dec range can end up inside.
        let slack = self.max_abs_pmdec * dt.abs() / MAS_PER_DEG + 1e-9;
        let r = radius_deg.min(180.0);
        let lo = self.stars.partition_point(|s| s.dec < dec_deg - r - slack);
        let hi = self.stars.partition_point(|s| s.dec <= dec_deg + r + slack);
        for s in &self.stars[lo..hi.max(lo)] {
            if s.mag > mag_max {
                continue;
            }
            let (ra, dec) = apply_proper_motion(s.ra, s.dec, s.pmra, s.pmdec, dt);
            if chord2(&radec_unit(ra, dec), &centre) <= max_chord2 {
                out.push(Star {
                    ra_deg: ra,
                    dec_deg: dec,
                    mag: s.mag,
                });
            }
        }
        sort_stars(&mut out);
        out
    }
}

/// Eq. 8 of the paper: `RA = ra + pmra dt / (3.6e6 cos dec)`, `DEC = dec + pmdec dt / 3.6e6`
/// (degrees, mas/yr, years; `pmra` is mu_alpha*). A star exactly at a pole keeps its RA; a
/// declination carried past a pole is folded back (RA + 180). RA is wrapped into [0, 360).
fn apply_proper_motion(ra: f64, dec: f64, pmra: f64, pmdec: f64, dt_years: f64) -> (f64, f64) {
    let cos_dec = dec.to_radians().cos();
    let mut ra_new = if cos_dec > 1e-12 {
        ra + pmra * dt_years / (MAS_PER_DEG * cos_dec)
    } else {
        ra
    };
    let mut dec_new = dec + pmdec * dt_years / MAS_PER_DEG;
    if dec_new > 90.0 {
        dec_new = 180.0 - dec_new;
        ra_new += 180.0;
    } else if dec_new < -90.0 {
        dec_new = -180.0 - dec_new;
        ra_new += 180.0;
    }
    (normalize_ra(ra_new), dec_new)
}

#[cfg(test)]
mod tests {
    use super::*;

    const BARNARD: (f64, f64, f64, f64) =
        (269.44850252543836, 4.739420051112412, -801.551, 10362.394);

    fn cat(text: &str) -> Result<StarCatalog, CatalogError> {
        StarCatalog::from_reader(text.as_bytes(), 2016.0)
    }

    #[test]
    fn parses_the_three_header_styles() {
        let gaia = "# Gaia archive export\nsource_id,ra,dec,pmra,pmdec,phot_g_mean_mag\n\
                    1,10.0,20.0,1.5,-2.5,12.25\n2,10.01,20.01,,,9.5\n";
        let vizier = "RA_ICRS,DE_ICRS,Source,pmRA,pmDE,Gmag\n10.0,20.0,1,1.5,-2.5,12.25\n10.01,20.01,2,,,9.5\n";
        let plain =
            "RA, DEC ,PMRA,PMDEC,MAG\n# comment\n 10.0 ,20.0,1.5,-2.5,12.25\n10.01,20.01,,,9.5\n";
        let nopm = "ra,dec,mag\n10.0,20.0,12.25\n10.01,20.01,9.5\n";
        let mut results = Vec::new();
        for text in [gaia, vizier, plain, nopm] {
            let c = cat(text).unwrap();
            assert_eq!(c.len(), 2);
            assert!(!c.is_empty());
            results.push(c.stars_in_cone(10.0, 20.0, 1.0, 20.0, 2016.0));
        }
        let expected = vec![
            Star {
                ra_deg: 10.01,
                dec_deg: 20.01,
                mag: 9.5,
            },
            Star {
                ra_deg: 10.0,
                dec_deg: 20.0,
                mag: 12.25,
            },
        ];
        for r in &results {
            assert_eq!(r, &expected);
        }
        // proper motion applies only where given
        let moved = cat(gaia)
            .unwrap()
            .stars_in_cone(10.0, 20.0, 1.0, 20.0, 2116.0);
        assert_eq!(moved[0], expected[0]);
        assert!((moved[1].dec_deg - (20.0 - 2.5 * 100.0 / 3.6e6)).abs() < 1e-12);
        assert!(cat("ra,dec,mag\n").unwrap().is_empty());
    }

    /// Barnard's star, Gaia DR3, 2016.0 -> 2022.5 (6.5 yr) by Eq. 8; reference figures from
    /// tests/reference/stars_reference.py (astropy's rigorous motion differs by 0.14 mas).
    #[test]
    fn proper_motion_is_eq_8() {
        let (ra, dec, pmra, pmdec) = BARNARD;
        let text = format!("ra,dec,pmra,pmdec,phot_g_mean_mag\n{ra},{dec},{pmra},{pmdec},8.19\n");
        let c = cat(&text).unwrap();
        let (ra1, dec1) = (269.4470503151456, 4.758129929167968);
        let s = c.stars_in_cone(ra1, dec1, 1e-4, 10.0, 2022.5);
        assert_eq!(s.len(), 1);
        assert!(
            (s[0].ra_deg - ra1).abs() < 1e-11 && (s[0].dec_deg - dec1).abs() < 1e-11,
            "{s:?}"
        );
        // it moved 67 arcsec: no longer at its 2016 place, and still there at 2016
        assert!(c.stars_in_cone(ra, dec, 0.01, 10.0, 2022.5).is_empty());
        assert_eq!(c.stars_in_cone(ra, dec, 1e-6, 10.0, 2016.0).len(), 1);
        // RA wrap backwards through 0 at dec 80 (reference figure from the script)
        let (r2, d2) = apply_proper_motion(0.001, 80.0, -5000.0, -2000.0, 10.0);
        assert!((r2 - 359.921017076623).abs() < 1e-11 && (d2 - 79.99444444444444).abs() < 1e-12);
        // pole crossing folds back
        let (r3, d3) = apply_proper_motion(10.0, 89.9999, 0.0, 1000.0, 1.0);
        assert!(
            (r3 - 190.0).abs() < 1e-12
                && (d3 - (90.0 - (89.9999 + 1.0 / 3600.0 - 90.0))).abs() < 1e-9
        );
        // a catalog cone query finds a fast star after it moved into the cone
        let c = cat("ra,dec,pmra,pmdec,mag\n10.0,-30.0,0,36000,5\n").unwrap();
        assert_eq!(c.stars_in_cone(10.0, -29.9, 0.001, 6.0, 2026.0).len(), 1);
        assert!(c.stars_in_cone(10.0, -29.9, 0.001, 4.0, 2026.0).is_empty());
    }

    fn err_text(text: &str) -> String {
        cat(text).unwrap_err().to_string()
    }

    #[test]
    fn malformed_rows_name_line_and_field() {
        // (catalog text, what its error message must contain)
        let cases: [(&str, &[&str]); 12] = [
            (
                "# c1\n# c2\nra,dec,pmra,pmdec,mag\n1,2,3,4,5\n1,2,x3,4,5\n",
                &["<reader>:5:", "`pmra`", "x3"],
            ),
            (
                "ra,dec,pmra,pmdec,phot_g_mean_mag\n1,2,3,4,5\n1,2,3,4,\n",
                &[":3:", "`phot_g_mean_mag`", "empty"],
            ),
            (
                "RA_ICRS,DE_ICRS,pmRA,pmDE,Gmag\n1,95,3,4,5\n",
                &[":2:", "`DE_ICRS`", "range"],
            ),
            ("ra,dec,mag\n1,2,3\n# note\n1,2\n", &[":4:", "2 fields"]),
            (
                "\u{feff}ra,dec,mag\r\n1,2,3\r\n\r\n#x\r\n  # y\r\n1,2\r\n",
                &["<reader>:6:", "2 fields"],
            ),
            (
                "\n\nra,dec,mag\r\n1,2,3\r\n1,2,3,4\r\n",
                &["<reader>:5:", "4 fields"],
            ),
            (
                "ra,dec,mag\n1,2,3\n\n\n\"1\",\"x\n\",3\n",
                &["<reader>:5:", "`dec`"],
            ),
            ("ra,dec,mag\n1,2,NaN\n", &[":2:", "`mag`", "finite"]),
            (
                "# only\nra,dec,pmra,pmdec\n1,2,3,4\n",
                &[":2:", "magnitude", "gmag"],
            ),
            ("ra,dec,gmag,mag\n", &[":1:", "`gmag`", "`mag`"]),
            ("", &["no header"]),
            ("# nothing\n", &["no header"]),
        ];
        for (text, needles) in cases {
            let e = err_text(text);
            assert!(needles.iter().all(|n| e.contains(n)), "{text:?}: {e}");
        }
    }

    #[test]
    fn files_are_named_in_errors() {
        let missing = Path::new("/nonexistent/dir/gaia-cone.csv");
        let e = StarCatalog::from_csv_path(missing, 2016.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/dir/gaia-cone.csv"), "{e}");
        let dir = std::env::temp_dir().join(format!("soig-stars-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.csv");
        std::fs::write(&path, "ra,dec,mag\n1,2,3\n1,abc,3\n").unwrap();
        let e = StarCatalog::from_csv_path(&path, 2016.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("{}:3:", path.display())) && e.contains("`dec`"),
            "{e}"
        );
        std::fs::write(&path, "ra,dec,mag\n1,2,3\n").unwrap();
        assert_eq!(StarCatalog::from_csv_path(&path, 2016.0).unwrap().len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
