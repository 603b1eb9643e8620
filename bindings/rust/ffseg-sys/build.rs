// Finds libffseg for the linker: FFSEG_LIB_DIR (a directory holding
// libffseg.so / libffseg.a) if set, otherwise `pkg-config --libs ffseg` (set
// PKG_CONFIG_PATH to <prefix>/lib/pkgconfig for a non-system prefix).
// FFSEG_STATIC=1 links the archive, with the C++ runtime it needs.
// Also passes the header's directory to this crate's own tests
// (FFSEG_SYS_INCLUDE_DIR), which compare the Rust layouts with the C compiler's.
use std::env;
use std::path::PathBuf;
use std::process::Command;

fn pkg_config(args: &[&str]) -> Option<String> {
    let exe = env::var("PKG_CONFIG").unwrap_or_else(|_| "pkg-config".to_string());
    let out = Command::new(exe).args(args).arg("ffseg").output().ok()?;
    if !out.status.success() {
        return None;
    }
    String::from_utf8(out.stdout).ok()
}

fn main() {
    for v in ["FFSEG_LIB_DIR", "FFSEG_INCLUDE_DIR", "FFSEG_STATIC", "PKG_CONFIG_PATH", "PKG_CONFIG"] {
        println!("cargo:rerun-if-env-changed={}", v);
    }
    let want_static = env::var("FFSEG_STATIC").map(|v| v == "1").unwrap_or(false);
    let kind = if want_static { "static" } else { "dylib" };

    let include: Option<PathBuf>;
    if let Some(dir) = env::var_os("FFSEG_LIB_DIR") {
        let dir = PathBuf::from(dir);
        println!("cargo:rustc-link-search=native={}", dir.display());
        println!("cargo:rustc-link-lib={}=ffseg", kind);
        if want_static {
            println!("cargo:rustc-link-lib=dylib=stdc++");
            println!("cargo:rustc-link-lib=dylib=m");
        }
        include = env::var_os("FFSEG_INCLUDE_DIR")
            .map(PathBuf::from)
            .or_else(|| dir.parent().map(|p| p.join("include")));
    } else {
        let mut args = vec!["--libs"];
        if want_static {
            args.push("--static");
        }
        let libs = pkg_config(&args).unwrap_or_else(|| {
            panic!(
                "ffseg-sys: FFSEG_LIB_DIR is not set and `pkg-config --libs ffseg` failed; \
                 install ffseg (make install PREFIX=P) and set PKG_CONFIG_PATH=P/lib/pkgconfig, \
                 or set FFSEG_LIB_DIR=P/lib"
            )
        });
        for tok in libs.split_whitespace() {
            if let Some(dir) = tok.strip_prefix("-L") {
                println!("cargo:rustc-link-search=native={}", dir);
            } else if let Some(name) = tok.strip_prefix("-l") {
                // Only ffseg itself switches kind; the C++ runtime and libm stay shared.
                let k = if name == "ffseg" { kind } else { "dylib" };
                println!("cargo:rustc-link-lib={}={}", k, name);
            }
        }
        include = env::var_os("FFSEG_INCLUDE_DIR").map(PathBuf::from).or_else(|| {
            pkg_config(&["--cflags-only-I"]).and_then(|s| {
                s.split_whitespace().find_map(|t| t.strip_prefix("-I").map(PathBuf::from))
            })
        });
    }
    if let Some(dir) = include {
        println!("cargo:include={}", dir.display());
        println!("cargo:rustc-env=FFSEG_SYS_INCLUDE_DIR={}", dir.display());
    }
}
