//! Throughput of `compensate` on a 1-million-block 5-axis program: the
//! rewrite with inverse kinematics on every block (and the path check that
//! decides subdivision), and, for comparison, parsing and re-printing
//! alone. The program is produced on the fly while it is read, so neither
//! it nor the output is ever held in memory; a counting allocator reports
//! the peak heap of a run with 100 000 and with 1 000 000 blocks to show
//! that memory does not grow with the file.
//!
//! Beside them, the parse alone of the same program by the `gcode` crate
//! (0.6.1), held in memory as one string as that crate needs it.
//!
//! Also: one inverse kinematics call on the closed-form fast path against
//! the generic `Kinematics::inverse` it replaces.
//!
//! Times are the benchmark thread's CPU time (`/proc/thread-self/schedstat`,
//! nanoseconds on the CPU), not wall-clock time: the machine's cores are
//! shared, and "blocks per second on one core" is what is being measured
//! (the rewrite there runs in the benchmark thread alone).
//!
//! `compensate` itself ([`Compensator::run`]) runs pipelined over two
//! threads (one reads, tokenizes and writes, the other interprets and
//! corrects): a thread's CPU time says nothing about that, so the group
//! "compensate 1M-block 5-axis program, wall clock" times it in wall-clock
//! time, beside the `gcode` peer's parse timed the same way. Wall-clock
//! figures depend on what else the machine runs: read them with the load
//! average (`uptime`) at the time.

use std::alloc::{GlobalAlloc, Layout, System};
use std::hint::black_box;
use std::io::{self, BufReader, Read};
use std::path::Path;
use std::rc::Rc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

#[path = "support/dome.rs"]
mod dome;

use criterion::measurement::{Measurement, ValueFormatter, WallTime};
use criterion::{
    BenchmarkGroup, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use fivecal::compensate::{Compensator, Settings};
use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::kinematics::Kinematics;
use fivecal::kinematics::fast::FastChain;
use fivecal::model::Context;
use fivecal::nc::{Block, BlockReader, Syntax};
use fivecal::{Axes, Dialect, Machine};

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(l) };
        if !p.is_null() {
            let now = LIVE.fetch_add(l.size(), Ordering::Relaxed) + l.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) };
        LIVE.fetch_sub(l.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// CPU time of the calling thread.
struct ThreadCpu {
    wall: WallTime,
}

fn thread_cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|v| v.parse().ok()))
        .expect("/proc/thread-self/schedstat (Linux) gives the thread's CPU time")
}

impl Measurement for ThreadCpu {
    type Intermediate = u64;
    type Value = Duration;

    fn start(&self) -> u64 {
        thread_cpu_ns()
    }
    fn end(&self, i: u64) -> Duration {
        Duration::from_nanos(thread_cpu_ns() - i)
    }
    fn add(&self, a: &Duration, b: &Duration) -> Duration {
        *a + *b
    }
    fn zero(&self) -> Duration {
        Duration::ZERO
    }
    fn to_f64(&self, v: &Duration) -> f64 {
        v.as_nanos() as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        self.wall.formatter()
    }
}

const BLOCKS: usize = 1_000_000;

/// The dome program of `support/dome.rs`, streamed: its distinct blocks,
/// generated once, are replayed until `blocks` have been read.
struct Program {
    lines: Rc<Vec<Vec<u8>>>,
    header: Vec<u8>,
    blocks: usize,
    next: usize,
    pos: usize,
    in_header: bool,
}

/// The distinct blocks of the program.
fn blocks(kin: &Kinematics) -> Rc<Vec<Vec<u8>>> {
    Rc::new(dome::blocks(kin))
}

impl Program {
    fn new(lines: &Rc<Vec<Vec<u8>>>, blocks: usize) -> Program {
        Program {
            lines: lines.clone(),
            header: dome::HEADER.to_vec(),
            blocks,
            next: 0,
            pos: 0,
            in_header: true,
        }
    }
}

impl Read for Program {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        let src: &[u8] = if self.in_header {
            &self.header
        } else {
            if self.next >= self.blocks {
                return Ok(0);
            }
            &self.lines[self.next % dome::DISTINCT]
        };
        let n = out.len().min(src.len() - self.pos);
        out[..n].copy_from_slice(&src[self.pos..self.pos + n]);
        self.pos += n;
        if self.pos == src.len() {
            self.pos = 0;
            if self.in_header {
                self.in_header = false;
            } else {
                self.next += 1;
            }
        }
        Ok(n)
    }
}

fn errors(kin: &Kinematics) -> LoadedErrors {
    ErrorFile::parse(Path::new("bench.yaml"), dome::ERRORS)
        .unwrap()
        .to_model(kin, Path::new("bench.yaml"), dome::ERRORS)
        .unwrap()
}

fn rewrite(c: &Compensator, program: Program) -> usize {
    let s = c
        .run(
            Path::new("dome.nc"),
            BufReader::with_capacity(1 << 16, program),
            &mut io::sink(),
        )
        .unwrap();
    s.moves
}

/// The rewrite in the calling thread alone.
fn rewrite_one(c: &Compensator, program: Program) -> usize {
    let s = c
        .run_chunked(
            Path::new("dome.nc"),
            BufReader::with_capacity(1 << 16, program),
            &mut io::sink(),
            None,
        )
        .unwrap();
    s.moves
}

fn reprint(program: Program) -> usize {
    let syn = Syntax {
        dialect: Dialect::Fanuc,
        strict: false,
    };
    let mut r = BlockReader::new(BufReader::with_capacity(1 << 16, program), Dialect::Fanuc);
    let mut b = Block::default();
    let mut out = Vec::with_capacity(256);
    let mut n = 0;
    while r.read(&mut b).unwrap() {
        syn.parse(&mut b).unwrap();
        out.clear();
        b.reprint(&mut out);
        io::Write::write_all(&mut io::sink(), &out).unwrap();
        n += 1;
    }
    n
}

fn peak_of(f: impl FnOnce()) -> usize {
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    f();
    PEAK.load(Ordering::Relaxed) - base
}

fn bench(c: &mut Criterion<ThreadCpu>) {
    let m = Machine::builtin("bc-trunnion").unwrap();
    let kin = Kinematics::new(&m);
    let l = errors(&kin);
    let comp = Compensator::new(&l.model, &l.theta, Settings::new(Dialect::Fanuc));
    assert!(comp.solver().is_fast());
    let lines = blocks(&kin);

    // Streaming: the peak heap of a run must not grow with the program.
    let small = peak_of(|| {
        black_box(rewrite(&comp, Program::new(&lines, BLOCKS / 10)));
    });
    let large = peak_of(|| {
        black_box(rewrite(&comp, Program::new(&lines, BLOCKS)));
    });
    let table = dome::DISTINCT * 64;
    println!(
        "peak heap: {} KiB for {} blocks, {} KiB for {} blocks (of which ~{} KiB is the generator's table of distinct blocks)",
        small / 1024,
        BLOCKS / 10,
        large / 1024,
        BLOCKS,
        table / 1024
    );
    // The chunks in flight between the pipeline's threads are a fixed
    // pool, but how full it gets, and which output buffer is still being
    // written when the peak is taken, depend on the threads' timing: the
    // shorter run has peaked anywhere from 5.0 to 6.7 MiB. Ten times the
    // blocks in less than twice the memory bounds any growth per block to
    // a few bytes (0.8 M blocks' worth would have to fit in the ~5 MiB the
    // shorter run needs anyway).
    assert!(
        large < 2 * small,
        "memory grows with the program: {small} -> {large} bytes"
    );

    let mut g = c.benchmark_group("compensate 1M-block 5-axis program");
    g.sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .measurement_time(Duration::from_secs(25))
        .warm_up_time(Duration::from_secs(3))
        .throughput(Throughput::Elements(BLOCKS as u64));
    g.bench_function(
        "rewrite with inverse kinematics on every block, one thread",
        |b| b.iter(|| rewrite_one(&comp, Program::new(&lines, BLOCKS))),
    );
    g.bench_function("parse and re-print only", |b| {
        b.iter(|| reprint(Program::new(&lines, BLOCKS)))
    });
    peer(&mut g, &lines);
    g.finish();
}

/// The peer: the `gcode` crate (0.6.1) parses a program held in memory as
/// one string, lossily (comments and unknown words dropped), and writes
/// nothing.
fn peer<M: Measurement>(g: &mut BenchmarkGroup<M>, lines: &Rc<Vec<Vec<u8>>>) {
    let mut whole = String::new();
    Program::new(lines, BLOCKS)
        .read_to_string(&mut whole)
        .unwrap();
    g.bench_function("peer: gcode 0.6.1 parse only, program in memory", |b| {
        b.iter(|| gcode::parse(black_box(&whole)).count())
    });
}

/// The pipelined rewrite as `compensate` runs it, and the peer, in
/// wall-clock time.
fn bench_wall(c: &mut Criterion) {
    let m = Machine::builtin("bc-trunnion").unwrap();
    let kin = Kinematics::new(&m);
    let l = errors(&kin);
    let comp = Compensator::new(&l.model, &l.theta, Settings::new(Dialect::Fanuc));
    let lines = blocks(&kin);
    let mut g = c.benchmark_group("compensate 1M-block 5-axis program, wall clock");
    g.sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .measurement_time(Duration::from_secs(15))
        .warm_up_time(Duration::from_secs(2))
        .throughput(Throughput::Elements(BLOCKS as u64));
    g.bench_function(
        "rewrite with inverse kinematics on every block, pipelined (2 threads)",
        |b| b.iter(|| rewrite(&comp, Program::new(&lines, BLOCKS))),
    );
    peer(&mut g, &lines);
    g.finish();
}

/// One inverse: closed form against the generic Newton-polished one
/// (wall-clock time: each call is far shorter than the CPU-time clock's
/// resolution).
fn bench_ik(c: &mut Criterion) {
    let m = Machine::builtin("bc-trunnion").unwrap();
    let kin = Kinematics::new(&m);
    let l = errors(&kin);
    let p = l.model.perturbation(&l.theta, &Context::default());
    let fast = FastChain::new(&kin, &p);
    let a = Axes::new(35.0, -20.0, 40.0, 37.5, 123.0);
    let target = kin.forward(&a, &p);
    let hint = Axes {
        tilt: 36.0,
        c: 120.0,
        ..a
    };
    let mut g = c.benchmark_group("inverse kinematics with location errors");
    g.bench_function("closed form (fast path)", |b| {
        b.iter(|| fast.inverse(black_box(&target), black_box(&hint)).unwrap())
    });
    g.bench_function("generic (Kinematics::inverse)", |b| {
        b.iter(|| kin.inverse(black_box(&target), Some(&hint), |_| p).unwrap())
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadCpu { wall: WallTime });
    targets = bench
}
criterion_group!(micro, bench_wall, bench_ik);
criterion_main!(benches, micro);
