//! An integrand wrapper for the examples: counts evaluations and lines, and may override the
//! choice of outer rule (`lean`). Evaluations go through `eval`, so every node counts once.
use furnace::quadrature::{Integrand2D, Panel, CHANNELS};
use std::cell::Cell;

pub struct Counted<'a, I: Integrand2D> {
    pub f: &'a I,
    /// `Some(l)`: use the full (false) or lean (true) outer rule instead of `f`'s choice.
    pub lean: Option<bool>,
    pub evals: Cell<usize>,
    pub lines: Cell<usize>,
}

impl<'a, I: Integrand2D> Counted<'a, I> {
    pub fn new(f: &'a I, lean: Option<bool>) -> Self {
        Counted {
            f,
            lean,
            evals: Cell::new(0),
            lines: Cell::new(0),
        }
    }
}

impl<'a, I: Integrand2D> Integrand2D for Counted<'a, I> {
    type Line = I::Line;
    fn outer_breaks(&self, o: &mut Vec<f64>) {
        self.f.outer_breaks(o)
    }
    fn line(&self, u: f64, b: &mut Vec<f64>) -> Self::Line {
        self.f.line(u, b)
    }
    fn eval(&self, l: &Self::Line, v: f64) -> [f64; CHANNELS] {
        self.evals.set(self.evals.get() + 1);
        self.f.eval(l, v)
    }
    fn outer_panels(&self, o: &mut Vec<Panel>) {
        self.f.outer_panels(o)
    }
    fn line_panels(&self, u: f64, o: &mut Vec<Panel>) -> Self::Line {
        self.lines.set(self.lines.get() + 1);
        self.f.line_panels(u, o)
    }
    fn lean_outer(&self) -> bool {
        self.lean.unwrap_or_else(|| self.f.lean_outer())
    }
    fn panels_all_active(&self) -> bool {
        self.f.panels_all_active()
    }
}
