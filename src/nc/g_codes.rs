//! The G codes the word-address dialects know (FANUC 30i-class controls,
//! LinuxCNC 2.9 with its five-axis remaps) and the number of a literal G
//! word: what the lexers check a word against and the interpreter
//! dispatches on, so both stand on it.

use crate::machine::Dialect;

/// G codes FANUC 30i-class controls know (value x 10).
const FANUC_G: &[u32] = &[
    0, 10, 20, 30, 40, 50, 51, 71, 80, 90, 100, 106, 110, 121, 131, 150, 160, 170, 180, 190, 200,
    210, 220, 230, 250, 260, 270, 280, 290, 300, 310, 311, 312, 313, 314, 330, 370, 390, 400, 410,
    412, 420, 422, 430, 434, 435, 440, 450, 460, 470, 480, 490, 500, 501, 510, 511, 520, 530, 531,
    536, 540, 541, 550, 560, 570, 580, 590, 600, 610, 620, 630, 640, 650, 660, 670, 680, 682, 683,
    684, 690, 730, 740, 760, 800, 810, 820, 830, 840, 850, 860, 870, 880, 890, 900, 910, 920, 930,
    940, 950, 960, 970, 980, 990, 2340, 2540, 2550,
];

/// G codes LinuxCNC 2.9 knows (value x 10).
const LINUXCNC_G: &[u32] = &[
    0, 10, 20, 30, 40, 50, 51, 52, 53, 70, 80, 100, 170, 171, 180, 181, 190, 191, 200, 210, 280,
    281, 300, 301, 330, 331, 382, 383, 384, 385, 400, 410, 411, 420, 421, 430, 431, 432, 490, 520,
    530, 540, 550, 560, 570, 580, 590, 591, 592, 593, 610, 611, 640, 700, 710, 720, 730, 740, 760,
    800, 810, 820, 830, 840, 850, 860, 870, 880, 890, 900, 901, 910, 911, 920, 921, 922, 923, 930,
    940, 950, 960, 970, 980, 990,
];

/// G codes LinuxCNC's five-axis configurations add by remapping (its
/// tilted-work-plane remap: G68.2, G68.3, G68.4, G53.1, G53.6, G69),
/// value x 10.
const LINUXCNC_REMAPPED_G: &[u32] = &[531, 536, 682, 683, 684, 690];

/// The G-code number of a literal G word value, times ten (`43.4` -> 434).
pub(crate) fn g_code(v: f64) -> Option<u32> {
    let t = (v * 10.0).round();
    ((v * 10.0 - t).abs() < 1e-6 && (0.0..1e9).contains(&t)).then_some(t as u32)
}

/// Whether the dialect knows G code `g` (x 10).
pub(crate) fn known_g(dialect: Dialect, g: u32) -> bool {
    match dialect {
        Dialect::Linuxcnc => {
            LINUXCNC_G.binary_search(&g).is_ok() || LINUXCNC_REMAPPED_G.contains(&g)
        }
        _ => FANUC_G.binary_search(&g).is_ok(),
    }
}
