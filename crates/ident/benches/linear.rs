//! Linear identification benchmarks (targets in BENCHMARKS.md):
//! ARX [4 4 1] on 1 000 000 samples < 50 ms, OE [2 2 1] on 100 000 samples < 1 s.

use std::hint::black_box;

use airsus_ident::linear::{ArxOrders, IdData, OeOrders, PemOptions, arx, oe};
use criterion::{Criterion, criterion_group, criterion_main};

#[path = "../tests/common/mod.rs"]
mod common;
use common::*;

fn arx_data(n: usize) -> IdData {
    let mut r = rng(101);
    let u = binary(&mut r, n, 0.3);
    let e = white(&mut r, n, 0.1);
    // Fourth-order, well damped: poles 0.9 ± 0.2i, 0.5 ± 0.3i.
    let a = conv(&[1.0, -1.8, 0.85], &[1.0, -1.0, 0.34]);
    let y = add(
        &lfilter(&[0.3, 0.2, 0.1, 0.05], 1, &a, &u),
        &lfilter(&[1.0], 0, &a, &e),
    );
    IdData::siso(y, u, 0.01).expect("valid")
}

fn oe_data(n: usize) -> IdData {
    let mut r = rng(102);
    let u = binary(&mut r, n, 0.2);
    let e = white(&mut r, n, 0.2);
    let y = add(&lfilter(&[0.5, 0.3], 1, &[1.0, -1.2, 0.5], &u), &e);
    IdData::siso(y, u, 0.01).expect("valid")
}

fn bench_arx(c: &mut Criterion) {
    let data = arx_data(1_000_000);
    let orders = ArxOrders::siso(4, 4, 1);
    let mut group = c.benchmark_group("linear");
    group.sample_size(20);
    group.bench_function("arx_4_4_1_1e6_samples", |b| {
        b.iter(|| arx(black_box(&data), black_box(&orders)).expect("arx"))
    });
    group.finish();
}

fn bench_oe(c: &mut Criterion) {
    let data = oe_data(100_000);
    let orders = OeOrders::siso(2, 2, 1);
    let options = PemOptions::default();
    let mut group = c.benchmark_group("linear");
    group.sample_size(10);
    group.bench_function("oe_2_2_1_1e5_samples", |b| {
        b.iter(|| oe(black_box(&data), black_box(&orders), &options).expect("oe"))
    });
    group.finish();
}

criterion_group!(benches, bench_arx, bench_oe);
criterion_main!(benches);
