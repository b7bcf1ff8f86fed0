//! Tools: T selects a tool table entry (its geometry offset), G40/G41/G42
//! hand the compensation mode on (`docs/compensation.md`).

use super::state::Interpreter;
use crate::canon::{Canon, CompMode};
use crate::geom::V3;
use crate::machine::tip_vector;
use crate::parse::Word;
use crate::source::ProgramSource;

impl<S: ProgramSource, C: Canon> Interpreter<S, C> {
    /// T: selects a tool table entry (lathe `T####`: the offset is the
    /// last two digits, 00 cancels it; mill `T<n>`: tool n). False: an
    /// error was reported.
    #[inline(never)]
    pub(super) fn select_tool(&mut self, n: u32, t: &Word) -> bool {
        if self.tools.is_empty() {
            return true;
        }
        let number = if self.lathe { n % 100 } else { n };
        if number == 0 {
            self.tool_cfg = None;
            self.canon.set_tool_offset(V3::zeros());
            return true;
        }
        match self.tools.iter().find(|x| x.number == number) {
            Some(cfg) => {
                self.canon.set_tool_offset(cfg.offset());
                self.tool_cfg = Some(cfg.clone());
                true
            }
            None => {
                let have: Vec<String> = self.tools.iter().map(|x| x.number.to_string()).collect();
                let what = if self.lathe {
                    format!("tool offset {number:02} (T{n:04})")
                } else {
                    format!("tool T{n}")
                };
                self.error(
                    Some(t),
                    format!(
                        "{what} is not in the machine's tool table (it has {})",
                        have.join(", ")
                    ),
                );
                false
            }
        }
    }

    /// G40/G41/G42.
    #[inline(never)]
    pub(super) fn exec_comp(&mut self, code: u8, g: &Word) {
        if code == 40 {
            self.canon.set_compensation(None, self.last);
            return;
        }
        let Some(tool) = self.tool_cfg.clone() else {
            self.error(
                Some(g),
                format!(
                    "G{code} (radius compensation) needs a tool from the machine's tool table: select one with T first"
                ),
            );
            return;
        };
        let r = tool.radius_mm;
        let mut tip = V3::zeros();
        if self.lathe {
            let (x, z) = tip_vector(tool.tip);
            tip[0] = x * r;
            tip[2] = z * r;
        }
        self.canon.set_compensation(
            Some(CompMode {
                side: if code == 41 { 1.0 } else { -1.0 },
                radius: r,
                plane: self.modal.plane,
                tip,
            }),
            self.last,
        );
    }
}
