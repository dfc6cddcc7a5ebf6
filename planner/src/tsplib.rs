//! TSPLIB files: reading symmetric 2-D instances (EUC_2D, CEIL_2D, ATT) and writing tours.

use crate::error::PlanError;
use crate::geom::Point;
use crate::tsp::{Instance, Metric};

/// A parsed TSPLIB instance.
#[derive(Debug, Clone)]
pub struct TsplibInstance {
    pub name: String,
    pub instance: Instance,
}

fn err(line: usize, msg: impl Into<String>) -> PlanError {
    PlanError::Tsplib { line, msg: msg.into() }
}

/// Largest DIMENSION read: the biggest instances of TSPLIB's library have 85 900 nodes; a
/// header claiming billions would otherwise allocate them before the first coordinate.
pub const MAX_DIMENSION: usize = 1_000_000;

/// What a TSPLIB header said so far.
#[derive(Default)]
struct Header {
    name: String,
    dim: Option<usize>,
    metric: Option<Metric>,
}

impl Header {
    /// One `KEY : value` line of the header.
    fn take(&mut self, line_no: usize, line: &str) -> Result<(), PlanError> {
        let (key, value) =
            line.split_once(':').map(|(k, v)| (k.trim(), v.trim())).ok_or_else(|| err(line_no, format!("expected `KEY : value`, got {line:?}")))?;
        match key {
            "NAME" => self.name = value.to_string(),
            "TYPE" if value != "TSP" => return Err(err(line_no, format!("TYPE {value} not supported (only symmetric TSP)"))),
            "TYPE" => {}
            "DIMENSION" => {
                let n: usize = value.parse().map_err(|_| err(line_no, format!("bad DIMENSION {value:?}")))?;
                if !(1..=MAX_DIMENSION).contains(&n) {
                    return Err(err(line_no, format!("DIMENSION must be in 1..={MAX_DIMENSION} (got {n})")));
                }
                self.dim = Some(n);
            }
            "EDGE_WEIGHT_TYPE" => {
                self.metric = Some(match value {
                    "EUC_2D" => Metric::EucRound,
                    "CEIL_2D" => Metric::Ceil,
                    "ATT" => Metric::Att,
                    other => return Err(err(line_no, format!("EDGE_WEIGHT_TYPE {other} not supported (EUC_2D, CEIL_2D, ATT)"))),
                })
            }
            "COMMENT" | "NODE_COORD_TYPE" | "DISPLAY_DATA_TYPE" => {}
            other => return Err(err(line_no, format!("unsupported keyword {other}"))),
        }
        Ok(())
    }
}

/// One `index x y` line of the NODE_COORD_SECTION into `points`.
fn coordinate(line_no: usize, line: &str, points: &mut [Option<Point>]) -> Result<(), PlanError> {
    let mut it = line.split_whitespace();
    let (Some(id), Some(x), Some(y), None) = (it.next(), it.next(), it.next(), it.next()) else {
        return Err(err(line_no, format!("expected `index x y`, got {line:?}")));
    };
    let n = points.len();
    let id: usize = id.parse().map_err(|_| err(line_no, format!("bad node index {id:?}")))?;
    if id == 0 || id > n {
        return Err(err(line_no, format!("node index {id} outside 1..={n}")));
    }
    let x: f64 = x.parse().map_err(|_| err(line_no, format!("bad x coordinate {x:?}")))?;
    let y: f64 = y.parse().map_err(|_| err(line_no, format!("bad y coordinate {y:?}")))?;
    if !(x.is_finite() && y.is_finite()) {
        return Err(err(line_no, "non-finite coordinate"));
    }
    if points[id - 1].replace(Point::new(x, y)).is_some() {
        return Err(err(line_no, format!("node {id} given twice")));
    }
    Ok(())
}

/// Parses TSPLIB text. Errors name the line.
pub fn parse(text: &str) -> Result<TsplibInstance, PlanError> {
    let mut header = Header::default();
    let mut points: Vec<Option<Point>> = Vec::new();
    let mut in_coords = false;
    let mut last_line = 0;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        last_line = line_no;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if line == "EOF" {
            break;
        }
        if in_coords {
            coordinate(line_no, line, &mut points)?;
        } else if line == "NODE_COORD_SECTION" {
            let n = header.dim.ok_or_else(|| err(line_no, "NODE_COORD_SECTION before DIMENSION"))?;
            if header.metric.is_none() {
                return Err(err(line_no, "NODE_COORD_SECTION before EDGE_WEIGHT_TYPE"));
            }
            points = vec![None; n];
            in_coords = true;
        } else {
            header.take(line_no, line)?;
        }
    }
    if !in_coords {
        return Err(err(last_line, "no NODE_COORD_SECTION"));
    }
    let mut pts = Vec::with_capacity(points.len());
    for (i, p) in points.into_iter().enumerate() {
        pts.push(p.ok_or_else(|| err(last_line, format!("node {} has no coordinates", i + 1)))?);
    }
    let metric = header.metric.ok_or_else(|| err(last_line, "no EDGE_WEIGHT_TYPE"))?;
    Ok(TsplibInstance { name: header.name, instance: Instance::new(pts, metric)? })
}

/// Writes a tour in TSPLIB TOUR format (1-based node ids, `-1` terminator).
pub fn write_tour(name: &str, order: &[usize], length: f64) -> String {
    let mut out = format!("NAME : {name}.tour\nCOMMENT : Length = {length}\nTYPE : TOUR\nDIMENSION : {}\nTOUR_SECTION\n", order.len());
    for &c in order {
        out.push_str(&(c + 1).to_string());
        out.push('\n');
    }
    out.push_str("-1\nEOF\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = "NAME : sq\nTYPE : TSP\nDIMENSION : 4\nEDGE_WEIGHT_TYPE : EUC_2D\nNODE_COORD_SECTION\n1 0 0\n2 0 10\n3 10 10\n4 10 0\nEOF\n";

    #[test]
    fn parses_small() {
        let t = parse(SMALL).expect("parse");
        assert_eq!(t.name, "sq");
        assert_eq!(t.instance.len(), 4);
        assert_eq!(t.instance.tour_length(&[0, 1, 2, 3]), 40.0);
    }

    #[test]
    fn errors_name_the_line() {
        let bad = SMALL.replace("3 10 10", "3 10 ten");
        assert_eq!(parse(&bad).unwrap_err().to_string(), "TSPLIB line 8: bad y coordinate \"ten\"");
        let bad = SMALL.replace("EUC_2D", "GEO");
        assert!(parse(&bad).unwrap_err().to_string().starts_with("TSPLIB line 4: EDGE_WEIGHT_TYPE GEO"));
        let bad = SMALL.replace("4 10 0\n", "");
        assert!(parse(&bad).unwrap_err().to_string().contains("node 4 has no coordinates"));
        let bad = SMALL.replace("4 10 0", "9 10 0");
        assert!(parse(&bad).unwrap_err().to_string().contains("outside 1..=4"));
        assert!(parse("").is_err());
        assert!(parse("garbage").unwrap_err().to_string().starts_with("TSPLIB line 1:"));
        // A header claiming billions of nodes is refused before anything is allocated.
        let huge = SMALL.replace("DIMENSION : 4", "DIMENSION : 100000000000");
        assert_eq!(parse(&huge).unwrap_err().to_string(), "TSPLIB line 3: DIMENSION must be in 1..=1000000 (got 100000000000)");
    }

    #[test]
    fn tour_format() {
        let s = write_tour("sq", &[0, 3, 2, 1], 40.0);
        assert!(s.contains("TOUR_SECTION\n1\n4\n3\n2\n-1\nEOF\n"));
    }

    #[test]
    fn att_and_ceil_metrics() {
        let att = Instance::new(vec![Point::new(0.0, 0.0), Point::new(10.0, 0.0)], Metric::Att).expect("att");
        // r = sqrt(100/10) = 3.162…, t = 3 < r → 4.
        assert_eq!(att.d(0, 1), 4.0);
        let ceil = Instance::new(vec![Point::new(0.0, 0.0), Point::new(1.0, 1.0)], Metric::Ceil).expect("ceil");
        assert_eq!(ceil.d(0, 1), 2.0);
    }

    proptest::proptest! {
        #[test]
        fn never_panics(s in "\\PC{0,300}") {
            let _ = parse(&s);
        }
    }
}
