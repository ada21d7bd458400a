//! Builders shared by the stiction-models test files.
#![allow(dead_code)]

use stiction_models::{He, Kano, KanoAsym};

pub fn kano(s: f64, j: f64) -> Kano {
    Kano::params()
        .s(s)
        .j(j)
        .check()
        .expect("valid Kano parameters")
}

pub fn he(fs: f64, fd: f64) -> He {
    He::params()
        .fs(fs)
        .fd(fd)
        .check()
        .expect("valid He parameters")
}

pub fn kano_asym(d: f64, j_up: f64, j_dn: f64) -> KanoAsym {
    KanoAsym::params()
        .d(d)
        .j_up(j_up)
        .j_dn(j_dn)
        .check()
        .expect("valid kano-asym parameters")
}
