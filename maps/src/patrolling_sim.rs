//! patrolling_sim's navigation graphs (`.graph`): whitespace-separated numbers, first a header
//! `vertices, width px, height px, resolution m/px, offset x m, offset y m`, then per vertex
//! `id, x px, y px, neighbour count` and per neighbour `id, direction (N NE E SE S SW W NW),
//! cost px`. Metres are pixels × resolution + offset (y up from the bottom of the image); an
//! edge is as long as its cost × resolution, as patrolling_sim measures it.

use crate::error::MapError;
use crate::geom::Point;
use crate::graph::{Edge, NavGraph, Vertex};
use crate::limits;

const DIRECTIONS: [&str; 8] = ["N", "NE", "E", "SE", "S", "SW", "W", "NW"];

struct Tokens<'a> {
    file: &'a str,
    it: std::iter::Peekable<Box<dyn Iterator<Item = (usize, &'a str)> + 'a>>,
    line: usize,
}

impl<'a> Tokens<'a> {
    fn new(file: &'a str, text: &'a str) -> Self {
        let it: Box<dyn Iterator<Item = (usize, &'a str)>> =
            Box::new(text.lines().enumerate().flat_map(|(i, l)| l.split_whitespace().map(move |t| (i + 1, t))));
        Tokens { file, it: it.peekable(), line: 1 }
    }

    fn next(&mut self, what: &str) -> Result<&'a str, MapError> {
        match self.it.next() {
            Some((line, t)) => {
                self.line = line;
                Ok(t)
            }
            None => Err(MapError::malformed(self.file, format!("line {}", self.line), format!("the file ends where {what} should be"))),
        }
    }

    fn err(&self, problem: String) -> MapError {
        MapError::malformed(self.file, format!("line {}", self.line), problem)
    }

    fn whole(&mut self, what: &str) -> Result<u64, MapError> {
        let t = self.next(what)?;
        t.parse::<u64>().map_err(|_| self.err(format!("{what}: {t:?} is not a whole number")))
    }

    fn number(&mut self, what: &str) -> Result<f64, MapError> {
        let t = self.next(what)?;
        t.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| self.err(format!("{what}: {t:?} is not a number")))
    }
}

/// Reads a patrolling_sim `.graph`; `file` names it in errors.
pub fn parse(file: &str, text: &str) -> Result<NavGraph, MapError> {
    if text.len() > limits::MAX_TEXT_BYTES {
        return Err(MapError::too_large(file, format!("{} bytes, at most {}", text.len(), limits::MAX_TEXT_BYTES)));
    }
    let mut t = Tokens::new(file, text);
    let n = t.whole("the number of vertices")?;
    if n == 0 || n > limits::MAX_VERTICES as u64 {
        return Err(t.err(format!("{n} vertices: give 1 to {}", limits::MAX_VERTICES)));
    }
    let _width = t.whole("the width in pixels")?;
    let _height = t.whole("the height in pixels")?;
    let res = t.number("the resolution")?;
    if !(res > 0.0 && res <= 100.0) {
        return Err(t.err(format!("resolution {res} is not a positive size of a pixel in metres (at most 100)")));
    }
    let (ox, oy) = (t.number("the offset x")?, t.number("the offset y")?);
    let mut vertices = Vec::with_capacity(n as usize);
    let mut edges = Vec::new();
    for i in 0..n {
        let id = t.whole("a vertex id")?;
        if id != i {
            return Err(t.err(format!("vertex id {id} where {i} was expected (ids count up from 0)")));
        }
        let (x, y) = (t.number("x")?, t.number("y")?);
        let count = t.whole("the neighbour count")?;
        if count > limits::MAX_NEIGHBOURS as u64 {
            return Err(t.err(format!("vertex {i} has {count} neighbours, at most {}", limits::MAX_NEIGHBOURS)));
        }
        for _ in 0..count {
            let to = t.whole("a neighbour id")?;
            if to >= n {
                return Err(t.err(format!("vertex {i}: neighbour {to} is not one of the {n} vertices")));
            }
            let dir = t.next("a direction")?;
            if !DIRECTIONS.contains(&dir) {
                return Err(t.err(format!("vertex {i}: direction {dir:?} is not one of {}", DIRECTIONS.join(" "))));
            }
            let cost = t.whole("a cost")?;
            edges.push(Edge { from: i as u32, to: to as u32, length: cost as f64 * res, passing: false });
        }
        vertices.push(Vertex { charger: false, name: i.to_string(), at: Point::new(x * res + ox, y * res + oy) });
    }
    if let Some((line, extra)) = t.it.next() {
        return Err(MapError::malformed(file, format!("line {line}"), format!("{extra:?} after the last of the {n} vertices")));
    }
    NavGraph { vertices, edges }.checked(file)
}
