//! Puts `memory.x` on the linker's search path (cortex-m-rt's `link.x` includes it), and writes
//! the list of model files the firmware carries in flash (`models.rs`, included by
//! `src/models.rs`): the files named in `IMADE_FIRMWARE_MODELS` (paths separated as in `PATH`),
//! or else every `fixtures/models/*.model`.

use std::{env, fs, io, path::PathBuf};

fn main() -> io::Result<()> {
    let out = PathBuf::from(env::var_os("OUT_DIR").ok_or(io::ErrorKind::NotFound)?);
    fs::copy("memory.x", out.join("memory.x"))?;
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-env-changed=IMADE_FIRMWARE_MODELS");
    let files = match env::var_os("IMADE_FIRMWARE_MODELS") {
        Some(list) => env::split_paths(&list).collect::<Vec<_>>(),
        None => {
            let bundled = PathBuf::from("../fixtures/models");
            println!("cargo:rerun-if-changed={}", bundled.display());
            let mut files = fs::read_dir(&bundled)?
                .map(|entry| entry.map(|e| e.path()))
                .collect::<io::Result<Vec<_>>>()?;
            files.retain(|p| p.extension().is_some_and(|e| e == "model"));
            files.sort();
            files
        }
    };
    let mut list = format!(
        "/// The model files in flash.\nstatic BUNDLED: [&[u8]; {}] = [\n",
        files.len()
    );
    for file in &files {
        let path = fs::canonicalize(file)
            .map_err(|e| io::Error::new(e.kind(), format!("model file {}: {e}", file.display())))?;
        println!("cargo:rerun-if-changed={}", path.display());
        list.push_str(&format!(
            "    include_bytes!({:?}),\n",
            path.display().to_string()
        ));
    }
    list.push_str("];\n");
    fs::write(out.join("models.rs"), list)
}
