//! Deterministic workload for `valgrind --tool=callgrind` instruction counts (the benches'
//! data, default orders): `profile_identify <name> <len> <reps> [predict]`.
//!
//! `valgrind --tool=callgrind --callgrind-out-file=/dev/null \
//!    target/release/examples/profile_identify arx 3000 10`

use linear_id::find_identifier;
use std::hint::black_box;

#[path = "../benches/data.rs"]
mod workload;
use workload::data;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("arx", String::as_str);
    let len: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3000);
    let reps: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(10);
    let what = args.get(4).map_or("identify", String::as_str);
    let id = find_identifier(name)
        .expect("registered")
        .build_default()
        .expect("defaults");
    let (u, y) = data(len);
    let fit = id.identify(&u, &y).expect("fit");
    let mut out = vec![0.0; len];
    for _ in 0..reps {
        match what {
            "predict" => fit
                .predict_one_step_into(black_box(&u), black_box(&y), &mut out)
                .expect("predict"),
            "simulate" => {
                black_box(fit.simulate(black_box(&u), &y[..2]).expect("sim"));
            }
            "stable" => {
                black_box(fit.poles());
            }
            _ => {
                black_box(id.identify(black_box(&u), black_box(&y)).expect("fit"));
            }
        }
    }
    println!("{name}: {:?}", fit.structure());
}
