//! `quantify`'s path as the CLI runs it on a record it has read: the loop kind decided, the
//! kano × arx grid at step 0.1 (`--step 0.1`), the detector (every test, the score and the
//! parts' check), the one answer and the repair estimate, on a simulated 3000-sample loop (the
//! paper's plant and PI, Kano S = 3, J = 1: `stiction simulate --valve kano --param S=3
//! --param J=1 --samples 3000`). Target: at most 60 ms of CPU (`cargo xtask bench quantify`;
//! the machine's other cores count too, so measure on one thread: `RAYON_NUM_THREADS=1`).

use datasets::simulate::Scenario;
use datasets::LoopData;
use monitoring::{analyse, Answer, Integrating};

/// The CLI's allocator, so the figures are the command's (`cli/src/main.rs`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    divan::main();
}

fn record() -> LoopData {
    Scenario {
        valve: Box::new(
            stiction_models::Kano::params()
                .s(3.0)
                .j(1.0)
                .check()
                .expect("valid"),
        ),
        samples: 3000,
        ..Scenario::default()
    }
    .simulate()
    .expect("simulates")
    .to_loop_data()
}

/// Everything `stiction quantify --step 0.1` computes between reading the file and printing.
#[divan::bench]
fn quantify_kano_arx_step_0_1_3000_samples(bencher: divan::Bencher) {
    let d = record();
    let args = run::SearchArgs {
        step: Some(0.1),
        ..run::SearchArgs::default()
    };
    let combination = args
        .settings(&["arx"])
        .expect("settings")
        .combination("kano", "arx")
        .expect("kano x arx");
    bencher.bench(|| {
        let d = divan::black_box(&d);
        let a = analyse(d, None, Integrating::Auto);
        let problem = run::problem(&a.searched).expect("PV");
        let fitted = combination.run(problem, None).expect("a best node");
        let det = a.detect(d);
        let answer = Answer::new(&a, &det.detected, Some(&fitted.result));
        let repair = fitted.repair(d, a.kind.integrating);
        (answer, repair.is_ok())
    });
}
