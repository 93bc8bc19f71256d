//! `@param`s in the window: selecting one, stepping it, and the model rebuilt with
//! the new value in the background.

use super::{App, UserEvent};
use crate::reload::Reloaded;

/// `p`'s value moved by `steps` steps — a bool flips; 1 for an int; a twentieth of the range, or
/// a tenth of the value (at least 0.1) for a float without one — rounded for ints
/// and clamped to the range. `None` when it would not change.
pub fn stepped(p: &mdg_vm::bundle::Param, steps: f64) -> Option<f64> {
    if p.ty == 2 {
        // A bool flips.
        return Some(if p.value != 0.0 { 0.0 } else { 1.0 });
    }
    let step = if p.ty == 0 {
        1.0
    } else if p.max > p.min {
        (p.max - p.min) / 20.0
    } else {
        (p.value.abs() * 0.1).max(0.1)
    };
    let mut v = p.value + steps * step;
    if p.ty == 0 {
        v = v.round();
    }
    if p.max > p.min {
        v = v.clamp(p.min, p.max);
    }
    (v != p.value && v.is_finite()).then_some(v)
}

impl App {
    /// Selects the next `@param` and shows it.
    pub(super) fn select_param(&mut self) {
        let Some(m) = &self.model else { return };
        let n = m.bundle.params.len();
        if n == 0 {
            (self.opts.log)("mdg-view: this grammar has no @param");
            return;
        }
        self.param = (self.param + 1) % n;
        self.show_param();
    }

    pub(super) fn show_param(&self) {
        let Some(m) = &self.model else { return };
        let Some(p) = m.bundle.params.get(self.param % m.bundle.params.len().max(1)) else { return };
        let range = if p.max > p.min { format!(" in [{}, {}]", p.min, p.max) } else { String::new() };
        let text = format!("{} = {}{range}", m.bundle.string(p.name), p.value);
        (self.opts.log)(&format!("mdg-view: @param {text}"));
        if let Some(g) = &self.gpu {
            g.window.set_title(&format!("mdg-view — {} — {text}", self.path.display()));
        }
    }

    /// Moves the selected `@param` by `steps` steps (1 for an int; a twentieth of
    /// the range, or a tenth of the value, for a float), clamped to its range, and
    /// rebuilds the model with it in the background.
    pub(super) fn change_param(&mut self, steps: f64) {
        let Some(m) = &self.model else { return };
        let Some(p) = m.bundle.params.get(self.param) else {
            (self.opts.log)("mdg-view: this grammar has no @param");
            return;
        };
        let Some(v) = stepped(p, steps) else { return };
        let name = m.bundle.string(p.name).to_string();
        let value = if p.ty == 0 { format!("{}", v as i64) } else { format!("{v}") };
        self.opts.load.params.retain(|(n, _)| *n != name);
        self.opts.load.params.push((name.clone(), value.clone()));
        if let Some(r) = &self.reload {
            r.set_options(self.opts.load.clone());
        }
        (self.opts.log)(&format!("mdg-view: @param {name} = {value}: rebuilding"));
        self.param_generation += 1;
        let generation = self.param_generation;
        let (path, opts, proxy) = (self.path.clone(), self.opts.load.clone(), self.proxy.clone());
        let loader = self.loader.clone();
        let spawned = std::thread::Builder::new().name("mdg-param".into()).spawn(move || {
            let r = match loader.load(&path, &opts) {
                Ok((m, _)) => Reloaded::Model(Box::new(m)),
                Err(fail) => Reloaded::Failed(fail.error.to_string()),
            };
            let _ = proxy.send_event(UserEvent::ParamRebuilt(generation, r));
        });
        if let Err(e) = spawned {
            (self.opts.log)(&format!("mdg-view: cannot rebuild: {e}"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::stepped;
    use mdg_vm::bundle::Param;

    #[test]
    fn param_steps_round_ints_clamp_to_the_range_and_scale_floats() {
        let int = Param { name: 0, ty: 0, value: 3.0, min: 1.0, max: 5.0 };
        assert_eq!(stepped(&int, 1.0), Some(4.0));
        assert_eq!(stepped(&int, 10.0), Some(5.0));
        assert_eq!(stepped(&Param { value: 5.0, ..int }, 1.0), None);
        assert_eq!(stepped(&int, -10.0), Some(1.0));
        let ranged = Param { name: 0, ty: 1, value: 0.5, min: 0.0, max: 2.0 };
        let near = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-12);
        assert!(near(stepped(&ranged, 1.0), 0.6));
        let free = Param { name: 0, ty: 1, value: 4.0, min: 0.0, max: 0.0 };
        assert!(near(stepped(&free, -1.0), 3.6));
        assert!(near(stepped(&Param { value: 0.0, ..free }, 1.0), 0.1));
        let flag = Param { name: 0, ty: 2, value: 1.0, min: 0.0, max: 0.0 };
        assert_eq!(stepped(&flag, 1.0), Some(0.0));
        assert_eq!(stepped(&Param { value: 0.0, ..flag }, -1.0), Some(1.0));
    }
}
