//! `mdas view`: writes `index.html` again in an output directory of
//! `compare`, `compare --samplers`, `sweep` or `tune` (`mdas::viewer`).

use super::*;

#[derive(clap::Args)]
pub(crate) struct ViewArgs {
    /// An output directory holding report.json (compare), sweep.json or
    /// tune.json, with the images and maps the record names.
    pub(crate) dir: PathBuf,
}

pub(crate) fn run(args: ViewArgs, ui: Ui) -> Result<()> {
    let dir = args.dir;
    if !dir.is_dir() {
        bail!("{} is not a directory", dir.display());
    }
    let kind = mdas::viewer::write_page(&dir)?;
    let page = dir.join(mdas::viewer::PAGE);
    ui.result(format!("{}\n", page.display()));
    ui.note(format!(
        "wrote the {} page; open it in a browser (it needs no server)",
        kind.name()
    ));
    ui.json(&serde_json::json!({
        "page": page,
        "kind": kind.name(),
    }))
}
