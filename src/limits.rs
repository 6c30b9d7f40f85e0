//! The bounds fivecal puts on what it reads, in one place so that
//! `docs/input-and-output.md` can list them: file sizes, YAML nesting, the
//! length of a line, and the plausible range of every error-file value and
//! machine-file number. A value outside its range is refused with its key,
//! its unit and the range: a location error of a metre is a unit mistake,
//! not a machine.

/// Largest YAML file read (machine, error, template, postprocessor,
/// manifest, contributors and tool files), bytes.
pub const MAX_YAML_BYTES: u64 = 8 << 20;
/// Largest measurement file read (DMIS, CSV, point list, probe log,
/// heights), bytes.
pub const MAX_MEASUREMENT_BYTES: u64 = 256 << 20;
/// Largest part model read by `analyze contour` (OBJ, glTF, GLB), bytes.
pub(crate) const MAX_MODEL_BYTES: u64 = 256 << 20;
/// Most nodes a glTF scene may place (a node shared by several parents
/// counts once per path to it).
pub(crate) const MAX_MODEL_NODES: usize = 100_000;
/// Most vertices a part model may have once its nodes are placed.
pub(crate) const MAX_MODEL_VERTICES: usize = 20_000_000;
/// Longest line of a file read line by line (an NC program), bytes.
pub const MAX_LINE_BYTES: usize = 1 << 20;
/// Deepest nesting of a YAML document (block levels and brackets
/// together); fivecal's own files nest at most five.
pub(crate) const MAX_YAML_DEPTH: usize = 64;

/// Deepest nesting of an NC expression (brackets and chained `#`
/// parameter references together): FANUC allows five levels of brackets.
pub const MAX_EXPR_DEPTH: usize = 64;

/// Most statements `compensate` executes when it runs a program's macro
/// logic (parameters, loops, jumps, calls): a loop that does not end
/// stops there with its line named instead of hanging.
pub const MAX_EXEC_STATEMENTS: usize = 2_000_000;
/// Deepest nesting of subprogram calls followed (FANUC allows 10
/// subprogram and 5 macro levels, LinuxCNC 10).
pub const MAX_CALL_DEPTH: usize = 16;

/// Longest line of a message fivecal prints for an error, characters:
/// what it quotes beyond that is cut.
pub const MESSAGE_CHARS: usize = 900;

/// Most characters of a whole message (many lines of [`MESSAGE_CHARS`] each).
pub const MESSAGE_TOTAL_CHARS: usize = 20_000;

/// Longest piece of the input an error message echoes, characters (cut
/// to its first line as well).
pub(crate) const ECHO_CHARS: usize = 60;

/// Largest location error, map value, straightness, tool radius or length
/// error, um (10 mm).
pub const MAX_ERROR_UM: f64 = 10_000.0;
/// Largest angular location error, map value or squareness, urad (10 mrad,
/// 0.57 deg).
pub(crate) const MAX_ERROR_URAD: f64 = 10_000.0;
/// Largest linear scale error, um/m (1 %).
pub(crate) const MAX_SCALE_UM_PER_M: f64 = 10_000.0;
/// Largest probe pre-travel, um.
pub(crate) const MAX_PRETRAVEL_UM: f64 = 1_000.0;
/// Largest measurement noise (standard deviation), um.
pub const MAX_NOISE_UM: f64 = 100.0;

/// Largest length in a machine file (strokes, pivot, table, head, tool,
/// probe), mm: 100 m.
pub const MAX_MACHINE_MM: f64 = 100_000.0;
/// Rapid rate of the linear axes, mm/min.
pub(crate) const RAPID_LINEAR_MM_PER_MIN: (f64, f64) = (100.0, 1_000_000.0);
/// Rapid rate of the rotary axes, deg/min.
pub(crate) const RAPID_ROTARY_DEG_PER_MIN: (f64, f64) = (100.0, 1_000_000.0);

/// Steps a postprocessor template may take to render one block (MiniJinja
/// fuel): the built-in templates take a few hundred.
pub(crate) const TEMPLATE_FUEL: u64 = 100_000;

/// Finest sampling step of `simulate nc --step`, mm.
pub const MIN_SAMPLE_STEP_MM: f64 = 0.001;
/// Most samples `simulate nc` keeps for `-o/--out` or `--cmm`.
pub const MAX_SAMPLES: usize = 2_000_000;
/// Finest `compensate --tolerance`, um (below any control's resolution).
pub const MIN_TOLERANCE_UM: f64 = 0.01;
/// Most pieces `compensate` splits one move into to stay within its
/// tolerance (an arc of a hundred million turns is refused, not made).
pub(crate) const MAX_PIECES: usize = 1 << 16;
/// Largest value of an axis, centre or radius word `compensate` and
/// `simulate nc` follow, mm (deg for the rotary axes): FANUC and
/// HEIDENHAIN take five integer digits (99999.999), so a larger value is a
/// control's alarm. Such a block is left as written, as a control would
/// not run it.
pub const MAX_NC_VALUE: f64 = 100_000.0;
/// Most Monte-Carlo runs of `analyze --mc`.
pub const MAX_MC_RUNS: usize = 100_000;

/// Finest length a test template may ask for (a step, a depth, a stepover,
/// a clearance), mm: 1 um, what a control's linear axes resolve.
pub(crate) const MIN_PLAN_MM: f64 = 0.001;
/// Largest length or position in a test template (a block, a column, a
/// sphere, a clearance, a probe), mm: 2 m. A block wider than the
/// machine's X or Y stroke is refused as well, once the machine is known.
pub(crate) const MAX_PLAN_MM: f64 = 2_000.0;
/// Largest angle in a test template, either way, deg: a C beyond a full
/// turn is a unit mistake.
pub(crate) const MAX_PLAN_DEG: f64 = 360.0;
/// Feeds of a test template (cutting, plunge, probing, positioning),
/// mm/min.
pub(crate) const PLAN_FEED_MM_PER_MIN: (f64, f64) = (1.0, 1_000_000.0);
/// Spindle speed of a test template, rpm.
pub(crate) const PLAN_SPINDLE_RPM: (f64, f64) = (1.0, 200_000.0);
/// Longest overhead (per touch, per pose) of a probing template, s.
pub(crate) const MAX_PLAN_OVERHEAD_S: f64 = 3_600.0;
/// Most turns of C along the probe-sphere spiral.
pub(crate) const MAX_PLAN_TURNS: f64 = 1_000.0;
/// Most entries of one list in a test template (angles, columns, top
/// points).
pub(crate) const MAX_PLAN_LIST: usize = 1_000;
/// Most poses of a plan.
pub(crate) const MAX_PLAN_POSES: usize = 10_000;
/// Most moves of a machining program, counted from the template before
/// any is made.
pub(crate) const MAX_PLAN_MOVES: usize = 100_000;
/// Most points of a plan (CMM points of a machining test, touches of a
/// probing test), counted before any is made.
pub(crate) const MAX_PLAN_POINTS: usize = 10_000;
/// Most (point, move) pairs a machining plan looks at: each CMM point is
/// traced back to the moves that made it, so the work grows with their
/// product (the limit keeps a plan within seconds).
pub(crate) const MAX_PLAN_POINT_MOVES: usize = 100_000_000;
