//! `fivecal analyze contour`: contour errors of CMM points against a part
//! model (Jiang et al. 2013): each point's signed distance to the design surface,
//! with mean, maximum and RMS.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Args;
use fivecal::contour::{PartMesh, Surface, evaluate};
use fivecal::formats::measured;

#[derive(Args, Debug)]
pub struct ContourArgs {
    /// Design model of the part (.obj, .gltf or .glb), in the CMM's frame.
    #[arg(long, value_name = "PART.obj|PART.glb")]
    model: PathBuf,
    /// Measured points, canonical CSV `label,x,y,z`.
    #[arg(long, value_name = "CMM.csv")]
    measured: PathBuf,
    /// Write each point's contour error as CSV.
    #[arg(short = 'o', long = "out", value_name = "ERRORS.csv")]
    output: Option<PathBuf>,
}

pub fn run(args: ContourArgs) -> anyhow::Result<()> {
    if let Some(o) = &args.output {
        fivecal::io::check_outputs(
            &[&args.model, &args.measured],
            &[("--out", o, fivecal::io::Shape::File)],
        )?;
    }
    let mesh = PartMesh::load(&args.model)?;
    let src = fivecal::input::read_text(
        &args.measured,
        "CSV file",
        fivecal::limits::MAX_MEASUREMENT_BYTES,
    )?;
    let points = measured::parse_csv(&args.measured, &src)?;
    anyhow::ensure!(
        !points.is_empty(),
        "{}: no measured points",
        args.measured.display()
    );
    // A coordinate no machine reaches (1e308) would make every statistic
    // below infinite: refused with its line instead.
    let max = fivecal::limits::MAX_MACHINE_MM;
    if let Some(p) = points
        .iter()
        .find(|p| !p.p.iter().all(|x| x.is_finite() && x.abs() <= max))
    {
        anyhow::bail!(
            "{}:{}: a coordinate of point `{}` is beyond any machine (each of x, y, z at most {max} mm from the model's origin)",
            args.measured.display(),
            p.line,
            fivecal::source::cut(&p.label)
        );
    }
    let surface = Surface::new(&mesh)?;
    let pts: Vec<(String, nalgebra::Vector3<f64>)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let label = if p.label.is_empty() {
                format!("#{}", i + 1)
            } else {
                p.label.clone()
            };
            (label, p.p)
        })
        .collect();
    let (per_point, s) = evaluate(&surface, &pts);
    if let Some(o) = &args.output {
        let mut t = String::from(
            "# contour error = signed distance to the design surface, um (positive: material left)\nlabel,x,y,z,error\n",
        );
        for p in &per_point {
            let _ = writeln!(
                t,
                "{},{:.6},{:.6},{:.6},{:.4}",
                p.label,
                p.measured.x,
                p.measured.y,
                p.measured.z,
                p.error * 1e3
            );
        }
        fivecal::io::write_atomic(o, t.as_bytes())?;
    }
    outln!(
        "contour errors of {} ({} points) against {} ({} triangles)",
        args.measured.display(),
        s.n,
        args.model.display(),
        mesh.triangles.len()
    );
    outln!("  mean |error| {:.4} mm", s.mean_abs);
    outln!(
        "  max  |error| {:.4} mm (point {})",
        s.max_abs.0,
        s.max_abs.1
    );
    outln!("  RMS          {:.4} mm", s.rms);
    outln!(
        "  signed: mean {:+.4} mm, from {:+.4} to {:+.4} mm",
        s.mean,
        s.range.0,
        s.range.1
    );
    if let Some(o) = &args.output {
        outln!("  per point: {}", o.display());
    }
    Ok(())
}
