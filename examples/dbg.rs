use isoc::eval::{Backend, Reference};
use isoc::interval::Interval;
use isoc::ir::{BinOp, Op, Program, UnOp, Value, Var};
fn main() {
    let p = Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Binary(BinOp::Add, Value(0), Value(0)),
            Op::Powi(Value(1), -9),
            Op::Binary(BinOp::Add, Value(2), Value(0)),
            Op::Unary(UnOp::Neg, Value(3)),
        ],
        output: Value(4),
    };
    let z = Interval { lo: 0.0, hi: 0.0 };
    let b = [
        Interval {
            lo: 0.0,
            hi: 5e-324,
        },
        z,
        z,
        z,
    ];
    let r = Reference(p.clone());
    println!("ref iv {:?}", r.interval(b));
    println!("ref grad {:?}", r.grad(b));
    let k = isoc::jit::Kernels::compile(&p).unwrap();
    println!("jit iv {:?}", k.interval(b));
    println!("jit grad {:?}", k.grad(b));
    println!("all {:?}", isoc::eval::interval::eval_all(&p, b));
}
