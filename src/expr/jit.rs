//! Tapes compiled to machine code with Cranelift, for the f64 evaluations
//! that run millions of times per render (a metric's derivatives, six
//! times per integrator step).
//!
//! Input: a [`Tape`]. Output: a [`CompiledTape`], a native function from
//! the inputs to the outputs, or `None` where this machine's instruction
//! set has no Cranelift backend or compiling fails; callers then keep the
//! interpreter. **A compiled tape gives bit for bit the interpreter's f64
//! results**: the IEEE operations (`+ - * /`, negation, `abs`, `sqrt`,
//! squares) are emitted as the same single instructions, in the same
//! order, with no fused multiply-adds, and every other operation calls
//! the very Rust function the interpreter uses ([`Unary::apply`](super::op::Unary::apply),
//! [`Binary::apply`](super::op::Binary::apply)). A test holds the two to the same bits over every
//! operation, NaN and infinities included.
//!
//! `NES_JIT=off` (or `0`, `false`, `no`) in the environment turns
//! compilation off, to compare.
//!
//! Why Cranelift and not a hand-written closure tree: the interpreter's
//! cost is its dispatch and slot traffic per operation (about 36
//! instructions per operation on Nil's 22-operation tape); native code
//! keeps every value in registers.

use std::mem::ManuallyDrop;

use cranelift_codegen::ir::{types, AbiParam, InstBuilder, MemFlagsData, Value};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{default_libcall_names, Linkage, Module};

use super::magnitude::{TINY, UNIT};
use super::number::{LineForm, Number};
use super::op::Noise;
use super::tape::{affine_terms, AffineTerm, Op, Tape, BINARY_OPS, UNARY_OPS};

extern "C" fn call_unary(code: u32, a: f64) -> f64 {
    UNARY_OPS[code as usize].apply(a)
}

extern "C" fn call_binary(code: u32, a: f64, b: f64) -> f64 {
    BINARY_OPS[code as usize].apply(a, b)
}

extern "C" fn call_select(condition: f64, then: f64, otherwise: f64) -> f64 {
    condition.select(then, otherwise)
}

extern "C" fn call_noise(partial: u32, x: f64, y: f64, z: f64) -> f64 {
    let [a, b, c, _] = partial.to_le_bytes();
    Noise { partial: [a, b, c] }.apply([x, y, z])
}

/// A tape as a native function: see the module's documentation.
pub struct CompiledTape {
    function: extern "C" fn(*const f64, *mut f64),
    /// How many inputs the function reads, and outputs it writes.
    inputs: usize,
    outputs: usize,
    /// The code's owner; freed on drop.
    module: ManuallyDrop<JITModule>,
}

// The module is touched only when compiling (before the value exists) and
// when dropping (with `&mut self`); in between the code is immutable and
// reads only its arguments, so calling it from any thread is safe.
unsafe impl Send for CompiledTape {}
unsafe impl Sync for CompiledTape {}

impl std::fmt::Debug for CompiledTape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "CompiledTape({} inputs, {} outputs)",
            self.inputs, self.outputs
        )
    }
}

impl Drop for CompiledTape {
    fn drop(&mut self) {
        // SAFETY: the function pointer dies with `self`, and nothing else
        // points into the module's memory.
        unsafe { ManuallyDrop::take(&mut self.module).free_memory() };
    }
}

/// Tapes longer than this are interpreted: Cranelift took about 45 us per
/// operation (measured: `nes check` on a metric of 3 000 sine terms, whose
/// tape has 39 029 operations, 2.09 s compiled against 0.34 s not), so
/// this bounds compiling near 1 s; and a compiled function keeps the
/// values it spills on the calling thread's stack, so its size stays well
/// below a thread's 2 MiB (8 bytes a value: at most 160 KiB).
pub const MAX_COMPILED_OPERATIONS: usize = 20_000;

/// Whether compilation is turned off: `NES_JIT` set to `off`, `0`,
/// `false` or `no`, in any case.
pub fn disabled() -> bool {
    std::env::var("NES_JIT").is_ok_and(|v| switch(&v) == Some(false))
}

/// `NES_JIT`'s value when it is set to neither on nor off (the command
/// line warns of it once: compiling then goes on as usual).
pub fn unrecognised_setting() -> Option<String> {
    let v = std::env::var("NES_JIT").ok()?;
    switch(&v).is_none().then_some(v)
}

fn switch(v: &str) -> Option<bool> {
    // Set but empty (`NES_JIT=`) is the default.
    if v.trim().is_empty() {
        return Some(true);
    }
    let is = |words: [&str; 4]| words.iter().any(|w| v.trim().eq_ignore_ascii_case(w));
    if is(["off", "0", "false", "no"]) {
        Some(false)
    } else if is(["on", "1", "true", "yes"]) {
        Some(true)
    } else {
        None
    }
}

impl CompiledTape {
    /// `tape` compiled, or `None` where that is not possible here (or is
    /// turned off).
    pub fn new(tape: &Tape) -> Option<CompiledTape> {
        if disabled() || tape.operations() > MAX_COMPILED_OPERATIONS {
            return None;
        }
        without_panics(|| compile(tape))
    }

    /// The outputs at `inputs`, as [`Tape::eval_into`] in f64 gives them
    /// (a missing input reads NaN; outputs beyond `out` are dropped).
    #[inline]
    pub fn eval_into(&self, inputs: &[f64], out: &mut [f64]) {
        if inputs.len() >= self.inputs && out.len() >= self.outputs {
            (self.function)(inputs.as_ptr(), out.as_mut_ptr());
            return;
        }
        let mut padded = vec![f64::NAN; self.inputs.max(inputs.len())];
        padded[..inputs.len()].copy_from_slice(inputs);
        let mut all = vec![0.0; self.outputs];
        (self.function)(padded.as_ptr(), all.as_mut_ptr());
        for (o, v) in out.iter_mut().zip(all) {
            *o = v;
        }
    }
}

fn compile(tape: &Tape) -> Result<CompiledTape, String> {
    let ((function, inputs), module) = build(|module| define(tape, module))?;
    Ok(CompiledTape {
        function,
        inputs,
        outputs: tape.outputs.len(),
        module: ManuallyDrop::new(module),
    })
}

type Compiled = (extern "C" fn(*const f64, *mut f64), usize);

fn define(tape: &Tape, module: &mut JITModule) -> Result<Compiled, String> {
    let fail = |e: &dyn std::fmt::Display| e.to_string();
    let pointer = module.target_config().pointer_type();
    let mut ctx = module.make_context();
    ctx.func.signature.params.push(AbiParam::new(pointer));
    ctx.func.signature.params.push(AbiParam::new(pointer));
    let signature = |params: &[types::Type]| {
        let mut s = module.make_signature();
        s.params.extend(params.iter().map(|&t| AbiParam::new(t)));
        s.returns.push(AbiParam::new(types::F64));
        s
    };
    let (i32t, f64t) = (types::I32, types::F64);
    let imports = [
        ("nes_unary", signature(&[i32t, f64t])),
        ("nes_binary", signature(&[i32t, f64t, f64t])),
        ("nes_select", signature(&[f64t, f64t, f64t])),
        ("nes_noise", signature(&[i32t, f64t, f64t, f64t])),
    ];
    let mut ids = Vec::new();
    for (name, sig) in &imports {
        ids.push(
            module
                .declare_function(name, Linkage::Import, sig)
                .map_err(|e| fail(&e))?,
        );
    }
    // Inputs read: the input slots' and, for affine steps, x, y and z.
    let mut inputs = tape
        .inputs
        .iter()
        .map(|&i| i as usize + 1)
        .max()
        .unwrap_or(0);
    if tape.steps.iter().any(|s| s.op == Op::Affine) {
        inputs = inputs.max(3);
    }
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let refs: Vec<_> = ids
            .iter()
            .map(|&id| module.declare_func_in_func(id, b.func))
            .collect();
        let (unary, binary, select, noise) = (refs[0], refs[1], refs[2], refs[3]);
        let block = b.create_block();
        b.append_block_params_for_function_params(block);
        b.switch_to_block(block);
        b.seal_block(block);
        let (input_ptr, output_ptr) = (b.block_params(block)[0], b.block_params(block)[1]);
        let flags = MemFlagsData::trusted();
        let coordinates: Vec<Value> = (0..inputs)
            .map(|i| b.ins().load(f64t, flags, input_ptr, 8 * i as i32))
            .collect();
        let mut slots: Vec<Value> =
            Vec::with_capacity(tape.constants.len() + tape.inputs.len() + tape.steps.len());
        for &c in &tape.constants {
            slots.push(b.ins().f64const(c));
        }
        for &i in &tape.inputs {
            slots.push(coordinates[i as usize]);
        }
        for step in &tape.steps {
            let a = || slots[step.a as usize];
            let v = match step.op {
                Op::Affine => {
                    let mut sum: Option<Value> = None;
                    for term in affine_terms(tape.affine[step.a as usize]) {
                        let v = match term {
                            AffineTerm::Coordinate(i) => coordinates[i],
                            AffineTerm::Scaled(c, i) => {
                                let k = b.ins().f64const(c);
                                b.ins().fmul(k, coordinates[i])
                            }
                            AffineTerm::Constant(c) => b.ins().f64const(c),
                        };
                        sum = Some(match sum {
                            Some(s) => b.ins().fadd(s, v),
                            None => v,
                        });
                    }
                    sum.ok_or("an affine step without a term")?
                }
                Op::Neg => b.ins().fneg(a()),
                Op::Square => b.ins().fmul(a(), a()),
                Op::Abs => b.ins().fabs(a()),
                Op::Sqrt => b.ins().sqrt(a()),
                Op::Add => b.ins().fadd(a(), slots[step.b as usize]),
                Op::Sub => b.ins().fsub(a(), slots[step.b as usize]),
                Op::Mul => b.ins().fmul(a(), slots[step.b as usize]),
                Op::Div => b.ins().fdiv(a(), slots[step.b as usize]),
                Op::Select => {
                    let [t, e] = tape.branches[step.b as usize];
                    let args = [a(), slots[t as usize], slots[e as usize]];
                    let call = b.ins().call(select, &args);
                    b.inst_results(call)[0]
                }
                Op::Noise => {
                    let (op, [x, y, z]) = tape.noise[step.a as usize];
                    let [p, q, r] = op.partial;
                    let code = u32::from_le_bytes([p, q, r, 0]);
                    let code = b.ins().iconst(i32t, i64::from(code));
                    let args = [
                        code,
                        slots[x as usize],
                        slots[y as usize],
                        slots[z as usize],
                    ];
                    let call = b.ins().call(noise, &args);
                    b.inst_results(call)[0]
                }
                op => {
                    // A paired sine or cosine is computed on its own: the
                    // interpreter's pair gives bit for bit the same.
                    if let Some(code) = op.unary_code() {
                        let code = b.ins().iconst(i32t, code as i64);
                        let call = b.ins().call(unary, &[code, a()]);
                        b.inst_results(call)[0]
                    } else {
                        let code = op.binary_code().ok_or("an operation without a code")?;
                        let code = b.ins().iconst(i32t, code as i64);
                        let call = b.ins().call(binary, &[code, a(), slots[step.b as usize]]);
                        b.inst_results(call)[0]
                    }
                }
            };
            slots.push(v);
        }
        for (k, &s) in tape.outputs.iter().enumerate() {
            b.ins()
                .store(flags, slots[s as usize], output_ptr, 8 * k as i32);
        }
        b.ins().return_(&[]);
        b.finalize(module.target_config());
    }
    let id = module
        .declare_function("tape", Linkage::Export, &ctx.func.signature)
        .map_err(|e| fail(&e))?;
    module.define_function(id, &mut ctx).map_err(|e| fail(&e))?;
    module.clear_context(&mut ctx);
    module.finalize_definitions().map_err(|e| fail(&e))?;
    let code = module.get_finalized_function(id);
    // SAFETY: the function was declared with two pointer parameters and
    // no result, the C calling convention's `fn(*const f64, *mut f64)`.
    let function =
        unsafe { std::mem::transmute::<*const u8, extern "C" fn(*const f64, *mut f64)>(code) };
    Ok((function, inputs))
}

/// A polynomial tape's [`Magnitude`](super::Magnitude) pass as native
/// code: the bound on the error of its `f64` values over a stretch of a
/// line that the polynomial route needs once per stretch, where the
/// interpreter spends about 40 instructions a step on it. The same
/// recurrences as [`Magnitude`](super::Magnitude)'s operations, in the
/// same order up to rounding (which the route's margin of 1e-9 covers).
pub struct CompiledMagnitude {
    function: extern "C" fn(*const f64, *const f64, *mut f64),
    forms: usize,
    module: ManuallyDrop<JITModule>,
}

// As for `CompiledTape`: the code is immutable once compiled.
unsafe impl Send for CompiledMagnitude {}
unsafe impl Sync for CompiledMagnitude {}

impl std::fmt::Debug for CompiledMagnitude {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "CompiledMagnitude({} forms)", self.forms)
    }
}

impl Drop for CompiledMagnitude {
    fn drop(&mut self) {
        // SAFETY: as for `CompiledTape`.
        unsafe { ManuallyDrop::take(&mut self.module).free_memory() };
    }
}

impl CompiledMagnitude {
    /// The pass for `tape`, or `None` where it uses an operation a
    /// polynomial does not (or compiling fails, or is turned off).
    pub fn new(tape: &Tape) -> Option<CompiledMagnitude> {
        if disabled() || tape.operations() > MAX_COMPILED_OPERATIONS {
            return None;
        }
        let (function, module) = without_panics(|| build(|module| define_magnitude(tape, module)))?;
        Some(CompiledMagnitude {
            function,
            forms: tape.inputs.len() + tape.affine.len(),
            module: ManuallyDrop::new(module),
        })
    }

    /// `(size, error)` of the tape's output over the stretch `[low,
    /// high]` of the line `forms` describe (as [`Tape::line_forms`] writes
    /// them), each point of it off by at most `parameter_error`; `None`
    /// if `forms` is not the tape's.
    #[inline]
    pub fn eval(
        &self,
        forms: &[LineForm],
        [low, high, parameter_error]: [f64; 3],
    ) -> Option<(f64, f64)> {
        if forms.len() != self.forms {
            return None;
        }
        let parameter = [low, high, parameter_error];
        let mut out = [0.0; 2];
        (self.function)(
            forms.as_ptr().cast::<f64>(),
            parameter.as_ptr(),
            out.as_mut_ptr(),
        );
        Some((out[0], out[1]))
    }
}

/// What `compile` makes, or `None` where it fails or panics: compiling is
/// an optimisation, and a tape it cannot handle (a bug here, or in
/// Cranelift) is interpreted rather than ending the render.
fn without_panics<T>(compile: impl FnOnce() -> Result<T, String>) -> Option<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(compile))
        .ok()
        .and_then(Result::ok)
}

/// A fresh module with the settings every compiled function here uses,
/// and what `define` makes in it; the module's memory is freed if
/// `define` fails.
fn build<T>(
    define: impl FnOnce(&mut JITModule) -> Result<T, String>,
) -> Result<(T, JITModule), String> {
    let fail = |e: &dyn std::fmt::Display| e.to_string();
    let mut flags = settings::builder();
    flags.set("opt_level", "speed").map_err(|e| fail(&e))?;
    flags
        .set("use_colocated_libcalls", "false")
        .map_err(|e| fail(&e))?;
    flags.set("is_pic", "false").map_err(|e| fail(&e))?;
    let isa = cranelift_native::builder()
        .map_err(|e| fail(&e))?
        .finish(settings::Flags::new(flags))
        .map_err(|e| fail(&e))?;
    let mut builder = JITBuilder::with_isa(isa, default_libcall_names());
    builder.symbol("nes_unary", call_unary as *const u8);
    builder.symbol("nes_binary", call_binary as *const u8);
    builder.symbol("nes_select", call_select as *const u8);
    builder.symbol("nes_noise", call_noise as *const u8);
    let mut module = JITModule::new(builder);
    match define(&mut module) {
        Ok(t) => Ok((t, module)),
        Err(e) => {
            // SAFETY: no function of the module escaped.
            unsafe { module.free_memory() };
            Err(e)
        }
    }
}

type MagnitudeFunction = extern "C" fn(*const f64, *const f64, *mut f64);

fn define_magnitude(tape: &Tape, module: &mut JITModule) -> Result<MagnitudeFunction, String> {
    let fail = |e: &dyn std::fmt::Display| e.to_string();
    let pointer = module.target_config().pointer_type();
    let mut ctx = module.make_context();
    for _ in 0..3 {
        ctx.func.signature.params.push(AbiParam::new(pointer));
    }
    let f64t = types::F64;
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let block = b.create_block();
        b.append_block_params_for_function_params(block);
        b.switch_to_block(block);
        b.seal_block(block);
        let params = b.block_params(block).to_vec();
        let (forms, parameter, out) = (params[0], params[1], params[2]);
        let flags = MemFlagsData::trusted();
        let low = b.ins().load(f64t, flags, parameter, 0);
        let high = b.ins().load(f64t, flags, parameter, 8);
        let parameter_error = b.ins().load(f64t, flags, parameter, 16);
        let unit = b.ins().f64const(UNIT);
        let tiny = b.ins().f64const(TINY);
        let one = b.ins().f64const(1.0);
        let zero = b.ins().f64const(0.0);
        let widen = b.ins().f64const(1.0 + 2.0 * f64::EPSILON);
        // `Magnitude::along` with a parameter over `[low, high]`.
        let along = |b: &mut FunctionBuilder, index: usize| -> (Value, Value) {
            let at = 32 * index as i32;
            let alpha = b.ins().load(f64t, flags, forms, at);
            let beta = b.ins().load(f64t, flags, forms, at + 8);
            let err = b.ins().load(f64t, flags, forms, at + 16);
            let slope_err = b.ins().load(f64t, flags, forms, at + 24);
            let p = b.ins().fmul(beta, low);
            let p = b.ins().fadd(alpha, p);
            let q = b.ins().fmul(beta, high);
            let q = b.ins().fadd(alpha, q);
            let (p, q) = (b.ins().fabs(p), b.ins().fabs(q));
            let size = b.ins().fmax(p, q);
            let size = b.ins().fmul(size, widen);
            let size = b.ins().fadd(size, err);
            let slope = b.ins().fabs(beta);
            let slope = b.ins().fadd(slope, slope_err);
            let moved = b.ins().fmul(slope, parameter_error);
            (size, b.ins().fadd(err, moved))
        };
        // `reach = size + error` of an operand.
        let reach = |b: &mut FunctionBuilder, (s, e): (Value, Value)| b.ins().fadd(s, e);
        let mul = |b: &mut FunctionBuilder, x: (Value, Value), y: (Value, Value)| {
            let (rx, ry) = (reach(b, x), reach(b, y));
            let size = b.ins().fmul(x.0, y.0);
            let e1 = b.ins().fmul(x.1, ry);
            let e2 = b.ins().fmul(x.0, y.1);
            let e3 = b.ins().fmul(rx, ry);
            let e3 = b.ins().fmul(unit, e3);
            let e = b.ins().fadd(e1, e2);
            let e = b.ins().fadd(e, e3);
            (size, b.ins().fadd(e, tiny))
        };
        let power = |b: &mut FunctionBuilder, x: Value, n: u32| -> Value {
            // By squarings; n >= 1.
            let (mut result, mut base, mut k) = (None, x, n);
            while k > 0 {
                if k & 1 == 1 {
                    result = Some(match result {
                        Some(r) => b.ins().fmul(r, base),
                        None => base,
                    });
                }
                k >>= 1;
                if k > 0 {
                    base = b.ins().fmul(base, base);
                }
            }
            result.unwrap_or(one)
        };
        let mut slots: Vec<(Value, Value)> = Vec::new();
        let mut constant: Vec<Option<f64>> = Vec::new();
        for &c in &tape.constants {
            slots.push((b.ins().f64const(c.abs()), zero));
            constant.push(Some(c));
        }
        for j in 0..tape.inputs.len() {
            slots.push(along(&mut b, j));
            constant.push(None);
        }
        for step in &tape.steps {
            // An affine step's `a` indexes the affine forms, not the slots.
            if step.op == Op::Affine {
                slots.push(along(&mut b, tape.inputs.len() + step.a as usize));
                constant.push(None);
                continue;
            }
            let x = slots[step.a as usize];
            let y = || slots[step.b as usize];
            let divisor = || constant[step.b as usize];
            let v = match step.op {
                Op::Neg => x,
                Op::Add | Op::Sub => {
                    let y = y();
                    let size = b.ins().fadd(x.0, y.0);
                    let (rx, ry) = (reach(&mut b, x), reach(&mut b, y));
                    let r = b.ins().fadd(rx, ry);
                    let r = b.ins().fmul(unit, r);
                    let e = b.ins().fadd(x.1, y.1);
                    let e = b.ins().fadd(e, r);
                    (size, b.ins().fadd(e, tiny))
                }
                Op::Mul => mul(&mut b, x, y()),
                Op::Square => mul(&mut b, x, x),
                Op::Div => match divisor() {
                    Some(c) if c != 0.0 && c.is_finite() => {
                        // Divided, as the interpreter does, not multiplied.
                        let by = b.ins().f64const(c.abs());
                        let size = b.ins().fdiv(x.0, by);
                        let r = reach(&mut b, x);
                        let r = b.ins().fmul(unit, r);
                        let e = b.ins().fadd(x.1, r);
                        let e = b.ins().fdiv(e, by);
                        (size, b.ins().fadd(e, tiny))
                    }
                    _ => return Err("division by a non-constant".into()),
                },
                Op::Pow => match divisor() {
                    Some(0.0) => (one, zero),
                    Some(n) if n > 0.0 && n.fract() == 0.0 && n <= 64.0 => {
                        let whole = n as u32;
                        let r = reach(&mut b, x);
                        let below = if whole == 1 {
                            one
                        } else {
                            power(&mut b, r, whole - 1)
                        };
                        let size = power(&mut b, x.0, whole);
                        let grow = b.ins().f64const(1.0 + n * f64::EPSILON);
                        let size = b.ins().fmul(size, grow);
                        let k = b.ins().f64const(n);
                        let e1 = b.ins().fmul(k, below);
                        let e1 = b.ins().fmul(e1, x.1);
                        let k2 = b.ins().f64const((n + 8.0) * f64::EPSILON);
                        let e2 = b.ins().fmul(k2, below);
                        let e2 = b.ins().fmul(e2, r);
                        let e = b.ins().fadd(e1, e2);
                        (size, b.ins().fadd(e, tiny))
                    }
                    _ => return Err("a power that is not whole".into()),
                },
                _ => return Err("an operation a polynomial does not use".into()),
            };
            slots.push(v);
            constant.push(None);
        }
        let &output = tape.outputs.first().ok_or("a tape without outputs")?;
        let (size, error) = slots[output as usize];
        b.ins().store(flags, size, out, 0);
        b.ins().store(flags, error, out, 8);
        b.ins().return_(&[]);
        b.finalize(module.target_config());
    }
    let id = module
        .declare_function("magnitude", Linkage::Export, &ctx.func.signature)
        .map_err(|e| fail(&e))?;
    module.define_function(id, &mut ctx).map_err(|e| fail(&e))?;
    module.clear_context(&mut ctx);
    module.finalize_definitions().map_err(|e| fail(&e))?;
    let code = module.get_finalized_function(id);
    // SAFETY: declared with three pointer parameters and no result.
    Ok(unsafe { std::mem::transmute::<*const u8, MagnitudeFunction>(code) })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit for bit the interpreter, over formulas that use every operation
    /// the language has, at ordinary points, far ones, zeros, infinities
    /// and NaN.
    #[test]
    fn a_compiled_tape_gives_the_interpreters_bits() {
        let formulas = [
            "x + y - z * 2 / (x - 0.5)",
            "-x + x^2 + abs(y) + sqrt(z) + sign(x - y)",
            "exp(x / 4) + ln(y) + sin(x) * cos(x) + tan(z)",
            "asin(x / 3) + acos(y / 3) + atan(z)",
            "sinh(x / 3) + cosh(y / 3) + tanh(z)",
            "floor(x) + fract(y) + pow(abs(z), 1.7) + y^z",
            "min(x, y) + max(y, z) + atan2(y, x) + smin(x, y, 0.3) + smin(z, x, 0.2)",
            "if x > 0 then y else z",
            "if x > 0 and y < 1 then sin(y) else x * z",
            "noise((x, y, z)) + 0.5 * noise((2 * x, y, 3 * z))",
            "sin(x) * cos(y) + sin(y) * cos(z) + sin(z) * cos(x)",
            "(2 * x - y / 4 + 3)^2 + 0 * z + 7",
            "sphere(1) translate (1, 2, 3)",
        ];
        let points = [
            [0.3, -0.7, 1.9],
            [-2.5, 4.0, 0.0],
            [0.0, -0.0, 0.0],
            [1e6, -3e5, 7.0],
            [f64::INFINITY, 1.0, -1.0],
            [f64::NEG_INFINITY, f64::NAN, 2.0],
            [1.0, 1.0, f64::NAN],
            [-1e-300, 1e-300, 5e-324],
        ];
        for formula in formulas {
            let src = format!("shape f = {formula}\ncamera {{ position (-5, 0, 0) }}\nobject f");
            let scene =
                crate::compile_source("t.nes", &src).unwrap_or_else(|e| panic!("{formula}: {e:?}"));
            let f = &scene.objects[0].function;
            for tape in [&f.value_tape, &f.gradient_tape] {
                let compiled = CompiledTape::new(tape).expect("compiles on this machine");
                let mut slots = Vec::new();
                let n = tape.output_count();
                for p in points {
                    let mut want = vec![0.0; n];
                    tape.eval_into(&p, &mut slots, &mut want);
                    let mut got = vec![0.0; n];
                    compiled.eval_into(&p, &mut got);
                    for (w, g) in want.iter().zip(&got) {
                        assert!(
                            w.to_bits() == g.to_bits() || (w.is_nan() && g.is_nan()),
                            "{formula} at {p:?}: interpreter {want:?}, compiled {got:?}"
                        );
                    }
                }
                // Fewer inputs than the tape reads: the missing read NaN.
                let mut want = vec![0.0; n];
                tape.eval_into(&[0.5], &mut slots, &mut want);
                let mut got = vec![0.0; n];
                compiled.eval_into(&[0.5], &mut got);
                for (w, g) in want.iter().zip(&got) {
                    assert!(w.to_bits() == g.to_bits() || (w.is_nan() && g.is_nan()));
                }
            }
        }
    }
}
