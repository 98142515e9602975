//! The Vulkan backend layer on the default device (lavapipe here) with validation on.
//!
//! Every test creates its own context and fails — never skips — when Vulkan, the driver or the
//! validation layer is missing. Each test ends with `Context::finish`, which tears the device
//! down and returns every validation message (leaks reported at device destruction included);
//! the tests require it to be empty.

use ash::vk;
use brdfwave::vk::{Context, ContextOptions, MemoryLocation, ShaderCompiler};

const STORAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::STORAGE_BUFFER;

fn context() -> Context {
    let ctx = Context::new(&ContextOptions {
        device: None,
        validation: true,
        ray_query: false,
    })
    .expect("a Vulkan 1.2 device; install lavapipe: sudo apt-get install mesa-vulkan-drivers");
    assert!(
        ctx.validation_enabled(),
        "VK_LAYER_KHRONOS_validation is required for these tests (sudo apt-get install vulkan-validationlayers)"
    );
    ctx
}

/// Tears the context down and fails on any validation message.
fn finish_clean(ctx: Context) {
    let msgs = ctx.finish();
    assert!(msgs.is_empty(), "validation messages:\n{}", msgs.join("\n"));
}

/// A compiler with no disk cache: the real shader root plus in-memory test files.
fn compiler(files: &[(&str, &str)]) -> ShaderCompiler {
    let mut c = ShaderCompiler::new()
        .expect("shaderc")
        .with_embedded_shaders()
        .without_cache();
    for (path, text) in files {
        c = c.with_source(path, text).unwrap();
    }
    c
}

const HELPERS: &str = r#"// test helpers
uint scale(uint x) { return x * FACTOR; }
"#;

/// Includes a real embedded file (common.glsl: PI), an in-memory helper and, through an
/// override, one of two "models".
const SCALE_COMP: &str = r#"#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "test/helpers.glsl"
#include "brdf/model.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) buffer Data { uint data[]; };
layout(push_constant) uniform Push { uint count; uint add; } pc;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    // PI comes from the embedded common.glsl: int(PI * 100) = 314.
    data[i] = model(scale(data[i]) + pc.add) + uint(PI * 100.0);
}
"#;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ScalePush {
    count: u32,
    add: u32,
}

#[test]
fn shared_types_are_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<Context>();
    check::<ShaderCompiler>();
}

#[test]
fn devices_are_listed_and_bad_names_rejected() {
    let devices = Context::list_devices().expect("list Vulkan devices");
    assert!(!devices.is_empty());
    let ctx = context();
    assert!(
        devices.iter().any(|d| d.starts_with(&ctx.device_name)),
        "{devices:?} vs {}",
        ctx.device_name
    );
    assert!(ctx.timestamp_period_ns > 0.0);
    assert!(ctx.limits.max_storage_buffer_range > 0);
    // Choosing by a case-insensitive substring of the name.
    let word = ctx
        .device_name
        .split_whitespace()
        .next()
        .unwrap()
        .to_uppercase();
    let again = Context::new(&ContextOptions {
        device: Some(word),
        validation: false,
        ray_query: false,
    })
    .expect("device by name");
    assert_eq!(again.device_name, ctx.device_name);
    drop(again);
    let err = Context::new(&ContextOptions {
        device: Some("no-such-gpu-xyz".into()),
        validation: false,
        ray_query: false,
    })
    .err()
    .expect("an unknown device name is an error");
    let text = format!("{err:#}");
    assert!(
        text.contains("no-such-gpu-xyz") && text.contains(&ctx.device_name),
        "{text}"
    );
    finish_clean(ctx);
}

#[test]
fn dispatch_with_include_define_and_override() {
    let ctx = context();
    let comp = compiler(&[
        ("test/scale.comp", SCALE_COMP),
        ("test/helpers.glsl", HELPERS),
        ("test/model_a.glsl", "uint model(uint x) { return x; }\n"),
        (
            "test/model_b.glsl",
            "uint model(uint x) { return 2u * x; }\n",
        ),
    ]);
    let defines = vec![("FACTOR".to_string(), "3u".to_string())];
    let n = 1000u32; // not a multiple of the workgroup size
    let input: Vec<u32> = (0..n).collect();
    for (model, factor_after) in [("test/model_a.glsl", 1u32), ("test/model_b.glsl", 2)] {
        let overrides = vec![("brdf/model.glsl".to_string(), model.to_string())];
        let spirv = comp
            .compile("test/scale.comp", &defines, &overrides)
            .expect("compile");
        let p = ctx
            .create_compute_pipeline("scale", &spirv, 1, 8)
            .expect("pipeline");
        assert_eq!(p.local_size_x, 64);
        assert_eq!(p.local_size, [64, 1, 1]);
        // One element more than dispatched, to see that the bound check holds.
        let mut data = input.clone();
        data.push(7);
        let buf = ctx.create_buffer_with_data("data", &data, STORAGE).unwrap();
        let set = ctx.create_descriptor_set(&p, &[&buf]).unwrap();
        let mut rec = ctx.begin().unwrap();
        rec.bind(&p, set);
        rec.push_constants(&p, &ScalePush { count: n, add: 5 });
        rec.dispatch(n.div_ceil(p.local_size_x), 1, 1);
        ctx.submit_and_wait(rec).unwrap();
        let out: Vec<u32> = ctx.download(&buf).unwrap();
        assert_eq!(out.len(), n as usize + 1);
        for i in 0..n {
            assert_eq!(
                out[i as usize],
                factor_after * (3 * i + 5) + 314,
                "element {i} with {model}"
            );
        }
        assert_eq!(out[n as usize], 7, "element past the count was written");
        ctx.destroy_buffer(buf);
        ctx.destroy_pipeline(p);
    }
    finish_clean(ctx);
}

/// The bindings and push constants that the three queue shaders below share.
const QUEUE_GLSL: &str = r#"// queue test interface
layout(std430, binding = 0) buffer Counter { uint counter; };
layout(std430, binding = 1) buffer Queue { uint queue[]; };
layout(std430, binding = 2) buffer Args { uint args[]; };
layout(std430, binding = 3) buffer Out { uint outv[]; };
layout(push_constant) uniform Push { uint count; uint modulus; uint mark; uint args_word; } pc;
"#;

/// A queue shader: the preamble the three share (the version, `local_size_x` and the queue
/// interface above), then `main` with the body given.
macro_rules! queue_comp {
    ($local_size_x:literal, $main_body:literal) => {
        concat!(
            "#version 450\n#extension GL_GOOGLE_include_directive : require\n",
            "layout(local_size_x = ",
            $local_size_x,
            ") in;\n#include \"t/queue.glsl\"\nvoid main() {\n",
            $main_body,
            "}\n"
        )
    };
}

/// Appends the indices i < count with i % modulus == 0 to a queue (atomic counter).
const PUSH_COMP: &str = queue_comp!(
    64,
    r#"    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count || i % pc.modulus != 0u) return;
    queue[atomicAdd(counter, 1u)] = i;
"#
);

/// One thread: the counter becomes a VkDispatchIndirectCommand at args[args_word..].
const PREPARE_COMP: &str = queue_comp!(
    1,
    r#"    args[pc.args_word + 0u] = (counter + 63u) / 64u;
    args[pc.args_word + 1u] = 1u;
    args[pc.args_word + 2u] = 1u;
"#
);

/// Consumes the queue: out[queue[k]] += mark for k < counter.
const CONSUME_COMP: &str = queue_comp!(
    64,
    r#"    uint k = gl_GlobalInvocationID.x;
    if (k >= counter) return;
    outv[queue[k]] += pc.mark;
"#
);

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct QueuePush {
    count: u32,
    modulus: u32,
    mark: u32,
    args_word: u32,
}

#[test]
fn indirect_dispatch_from_counter_in_one_command_buffer() {
    let ctx = context();
    let comp = compiler(&[
        ("t/queue.glsl", QUEUE_GLSL),
        ("t/push.comp", PUSH_COMP),
        ("t/prepare.comp", PREPARE_COMP),
        ("t/consume.comp", CONSUME_COMP),
    ]);
    let pipe = |name: &str, file: &str| {
        let spirv = comp.compile(file, &[], &[]).unwrap();
        ctx.create_compute_pipeline(name, &spirv, 4, 16).unwrap()
    };
    let (push, prepare, consume) = (
        pipe("push", "t/push.comp"),
        pipe("prepare", "t/prepare.comp"),
        pipe("consume", "t/consume.comp"),
    );
    let n = 10_000u32;
    let gpu = MemoryLocation::GpuOnly;
    let counter = ctx.create_buffer("counter", 4, STORAGE, gpu).unwrap();
    let queue = ctx
        .create_buffer("queue", 4 * n as u64, STORAGE, gpu)
        .unwrap();
    // Two argument records; the second one is used, at a nonzero offset.
    let args = ctx
        .create_buffer(
            "args",
            32,
            STORAGE | vk::BufferUsageFlags::INDIRECT_BUFFER,
            gpu,
        )
        .unwrap();
    let out = ctx
        .create_buffer("out", 4 * n as u64, STORAGE, MemoryLocation::GpuToCpu)
        .unwrap();
    let bufs = [&counter, &queue, &args, &out];
    let sets: Vec<_> = [&push, &prepare, &consume]
        .iter()
        .map(|p| ctx.create_descriptor_set(p, &bufs).unwrap())
        .collect();

    let mut rec = ctx.begin().unwrap();
    rec.fill_buffer(&out, 0);
    // Two rounds in the same command buffer: modulus 3 marks 1, modulus 5 marks 10.
    for (modulus, mark) in [(3u32, 1u32), (5, 10)] {
        let pc = QueuePush {
            count: n,
            modulus,
            mark,
            args_word: 4,
        };
        rec.fill_buffer(&counter, 0);
        rec.bind(&push, sets[0]);
        rec.push_constants(&push, &pc);
        rec.dispatch(n.div_ceil(push.local_size_x), 1, 1);
        rec.barrier();
        rec.bind(&prepare, sets[1]);
        rec.push_constants(&prepare, &pc);
        rec.dispatch(1, 1, 1);
        rec.barrier();
        rec.bind(&consume, sets[2]);
        rec.push_constants(&consume, &pc);
        rec.dispatch_indirect(&args, 16);
        rec.barrier();
    }
    ctx.submit_and_wait(rec).unwrap();

    let result: Vec<u32> = ctx.download(&out).unwrap();
    for (i, &v) in result.iter().enumerate() {
        let expect = (i % 3 == 0) as u32 + 10 * (i % 5 == 0) as u32;
        assert_eq!(v, expect, "element {i}");
    }
    let a: Vec<u32> = ctx.download(&args).unwrap();
    assert_eq!(
        &a[4..7],
        &[(n / 5).div_ceil(64), 1, 1],
        "arguments of the last round"
    );
    for b in [counter, queue, args, out] {
        ctx.destroy_buffer(b);
    }
    for p in [push, prepare, consume] {
        ctx.destroy_pipeline(p);
    }
    finish_clean(ctx);
}

/// Some arithmetic per element, so that dispatches take measurable time.
const BUSY_COMP: &str = r#"#version 450
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Data { float data[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    float x = data[i];
    for (int k = 0; k < 64; k++) x = sin(x) * 0.5 + 0.25;
    data[i] = x;
}
"#;

/// BUSY_COMP's SPIR-V (one storage buffer, no push constants of its own).
fn busy_spirv() -> Vec<u32> {
    let comp = compiler(&[("t/busy.comp", BUSY_COMP)]);
    comp.compile("t/busy.comp", &[], &[]).unwrap()
}

#[test]
fn timestamps_are_labelled_and_monotonic() {
    let ctx = context();
    assert!(
        ctx.features.timestamps,
        "the compute queue has no timestamps"
    );
    let p = ctx
        .create_compute_pipeline("busy", &busy_spirv(), 1, 0)
        .unwrap();
    let n = 1 << 16;
    let buf = ctx
        .create_buffer_with_data("busy", &vec![0.5f32; n], STORAGE)
        .unwrap();
    let set = ctx.create_descriptor_set(&p, &[&buf]).unwrap();
    let labels = ["start", "first", "second", "third"];
    let mut rec = ctx.begin().unwrap();
    rec.timestamp(labels[0]);
    rec.bind(&p, set);
    for l in &labels[1..] {
        rec.dispatch(n as u32 / 64, 1, 1);
        rec.barrier();
        rec.timestamp(l);
    }
    assert!(
        ctx.read_timestamps().is_err(),
        "timestamps read before submission"
    );
    ctx.submit_and_wait(rec).unwrap();
    let stamps = ctx.read_timestamps().unwrap();
    let got: Vec<&str> = stamps.iter().map(|(l, _)| l.as_str()).collect();
    assert_eq!(got, labels);
    assert_eq!(stamps[0].1, 0.0);
    for w in stamps.windows(2) {
        assert!(w[1].1 >= w[0].1, "not monotonic: {stamps:?}");
    }
    assert!(
        stamps[3].1 > 0.0,
        "three busy dispatches took no time: {stamps:?}"
    );
    assert!(stamps[3].1 < 60.0, "implausible duration: {stamps:?}");
    // A staging transfer or a recorder without timestamps leaves them alone; a new begin()
    // replaces them.
    let _: Vec<f32> = ctx.download(&buf).unwrap();
    assert_eq!(ctx.read_timestamps().unwrap().len(), 4);
    let rec = ctx.begin().unwrap();
    ctx.submit_and_wait(rec).unwrap();
    assert!(ctx.read_timestamps().unwrap().is_empty());
    ctx.destroy_buffer(buf);
    ctx.destroy_pipeline(p);
    finish_clean(ctx);
}

#[test]
fn spirv_cache_hits_misses_and_corruption() {
    let dir = tempfile::tempdir().unwrap();
    let files = [
        ("test/scale.comp", SCALE_COMP),
        ("test/helpers.glsl", HELPERS),
        ("test/m.glsl", "uint model(uint x) { return x; }\n"),
    ];
    let make = |helpers: &str| {
        let mut c = ShaderCompiler::new()
            .unwrap()
            .with_embedded_shaders()
            .with_cache_dir(dir.path());
        for (p, t) in files {
            c = c
                .with_source(p, if p == "test/helpers.glsl" { helpers } else { t })
                .unwrap();
        }
        c
    };
    let defines = vec![("FACTOR".to_string(), "3u".to_string())];
    let overrides = vec![("brdf/model.glsl".to_string(), "test/m.glsl".to_string())];
    let c = make(HELPERS);
    let first = c
        .compile_detailed("test/scale.comp", &defines, &overrides)
        .unwrap();
    assert!(!first.from_cache);
    let second = c
        .compile_detailed("test/scale.comp", &defines, &overrides)
        .unwrap();
    assert!(second.from_cache, "second compile missed the cache");
    assert_eq!(first.spirv, second.spirv);
    let s = c.stats();
    assert_eq!((s.compiled, s.cache_hits, s.corrupt_entries), (1, 1, 0));
    assert!(s.compile_seconds > 0.0 && s.cache_seconds > 0.0);
    eprintln!(
        "compile {:.1} ms, cache hit {:.2} ms",
        s.compile_seconds * 1e3,
        s.cache_seconds * 1e3
    );
    let entry = c
        .spirv_cache_dir()
        .unwrap()
        .join(format!("{:016x}.spv", first.key));
    assert!(entry.is_file());

    // Everything that changes the output changes the key.
    let other_define = vec![("FACTOR".to_string(), "4u".to_string())];
    assert!(
        !c.compile_detailed("test/scale.comp", &other_define, &overrides)
            .unwrap()
            .from_cache
    );
    let other_override = vec![(
        "brdf/model.glsl".to_string(),
        "test/helpers.glsl".to_string(),
    )];
    let e = c.compile_detailed("test/scale.comp", &defines, &other_override);
    assert!(e.is_err(), "model() is undefined with that override");
    let changed_include = make("uint scale(uint x) { return x * FACTOR + 1u; }\n");
    let third = changed_include
        .compile_detailed("test/scale.comp", &defines, &overrides)
        .unwrap();
    assert!(
        !third.from_cache,
        "an edited include file must miss the cache"
    );
    assert_ne!(third.key, first.key);

    // A damaged entry is recompiled (and rewritten), not used.
    let mut bytes = std::fs::read(&entry).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0xff;
    std::fs::write(&entry, &bytes).unwrap();
    let c2 = make(HELPERS);
    let again = c2
        .compile_detailed("test/scale.comp", &defines, &overrides)
        .unwrap();
    assert!(!again.from_cache);
    assert_eq!(again.spirv, first.spirv);
    assert_eq!(c2.stats().corrupt_entries, 1);
    assert!(
        c2.compile_detailed("test/scale.comp", &defines, &overrides)
            .unwrap()
            .from_cache
    );
    std::fs::write(&entry, b"short").unwrap();
    assert!(
        !make(HELPERS)
            .compile_detailed("test/scale.comp", &defines, &overrides)
            .unwrap()
            .from_cache
    );

    // The cached module runs (round trip through a pipeline).
    let ctx = context();
    let p = ctx
        .create_compute_pipeline("cached", &second.spirv, 1, 8)
        .unwrap();
    ctx.destroy_pipeline(p);
    finish_clean(ctx);
}

#[test]
fn compile_errors_name_file_and_line() {
    let bad_include = "// line 1\nuint helper() {\n    return undefined_thing;\n}\n";
    let top = "#version 450\n#extension GL_GOOGLE_include_directive : require\n#include \"t/bad.glsl\"\nlayout(local_size_x = 1) in;\nvoid main() {}\n";
    let c = compiler(&[("t/top.comp", top), ("t/bad.glsl", bad_include)]);
    let err = format!("{:#}", c.compile("t/top.comp", &[], &[]).unwrap_err());
    assert!(err.contains("t/bad.glsl:3"), "{err}");
    assert!(err.contains("undefined_thing"), "{err}");

    let syntax = "#version 450\nlayout(local_size_x = 1) in;\nvoid main() {\n    int x = ;\n}\n";
    let c = compiler(&[("t/syntax.comp", syntax)]);
    let err = format!("{:#}", c.compile("t/syntax.comp", &[], &[]).unwrap_err());
    assert!(err.contains("t/syntax.comp:4"), "{err}");

    let missing = "#version 450\n#extension GL_GOOGLE_include_directive : require\n#include \"t/nope.glsl\"\nlayout(local_size_x = 1) in;\nvoid main() {}\n";
    let c = compiler(&[("t/missing.comp", missing)]);
    let err = format!("{:#}", c.compile("t/missing.comp", &[], &[]).unwrap_err());
    assert!(
        err.contains("t/nope.glsl") && err.contains("t/missing.comp"),
        "{err}"
    );

    let err = format!(
        "{:#}",
        c.compile("t/does_not_exist.comp", &[], &[]).unwrap_err()
    );
    assert!(err.contains("t/does_not_exist.comp"), "{err}");
    let err = format!(
        "{:#}",
        c.compile("t/missing.comp", &[("BAD NAME".into(), "1".into())], &[])
            .unwrap_err()
    );
    assert!(err.contains("BAD NAME"), "{err}");
}

/// A generated source shadows the file of its name for that one compilation, and its text is
/// part of the cache key (the wavefront kernels' interface header comes this way).
#[test]
fn generated_sources_shadow_files_and_key_the_cache() {
    let top =
        "#version 450\n#extension GL_GOOGLE_include_directive : require\n#include \"t/gen.glsl\"\n\
               layout(local_size_x = 1) in;\nlayout(std430, binding = 0) buffer D { uint d[]; };\n\
               void main() { d[0] = GENERATED; }\n";
    let dir = tempfile::tempdir().unwrap();
    let c = compiler(&[
        ("t/top.comp", top),
        ("t/gen.glsl", "#error not generated\n"),
    ])
    .with_cache_dir(dir.path());
    let err = format!("{:#}", c.compile("t/top.comp", &[], &[]).unwrap_err());
    assert!(err.contains("not generated"), "{err}");
    let gen = |v: &str| {
        vec![(
            "t/gen.glsl".to_string(),
            format!("#define GENERATED {v}u\n"),
        )]
    };
    let one = c
        .compile_generated("t/top.comp", &[], &[], &gen("1"))
        .unwrap();
    let two = c
        .compile_generated("t/top.comp", &[], &[], &gen("2"))
        .unwrap();
    assert!(!two.from_cache, "other generated text must miss the cache");
    assert_ne!(one.key, two.key);
    assert_ne!(one.spirv, two.spirv);
    let again = c
        .compile_generated("t/top.comp", &[], &[], &gen("1"))
        .unwrap();
    assert!(again.from_cache);
    assert_eq!(again.spirv, one.spirv);
    // Nothing stays behind: without it, the file is read again.
    assert!(c.compile("t/top.comp", &[], &[]).is_err());
}

#[test]
fn shader_dir_overrides_embedded_sources() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("k")).unwrap();
    std::fs::write(dir.path().join("common.glsl"), "#define ANSWER 42u\n").unwrap();
    std::fs::write(
        dir.path().join("k/answer.comp"),
        "#version 450\n#extension GL_GOOGLE_include_directive : require\n#include \"common.glsl\"\n\
         layout(local_size_x = 8) in;\nlayout(std430, binding = 0) buffer D { uint d[]; };\n\
         void main() { d[gl_GlobalInvocationID.x] = ANSWER; }\n",
    )
    .unwrap();
    let c = ShaderCompiler::new()
        .unwrap()
        .with_shader_dir(dir.path())
        .without_cache();
    let spirv = c.compile("k/answer.comp", &[], &[]).unwrap();
    let ctx = context();
    let p = ctx.create_compute_pipeline("answer", &spirv, 1, 0).unwrap();
    assert_eq!(p.local_size_x, 8);
    let buf = ctx
        .create_buffer("answer", 64, STORAGE, MemoryLocation::GpuOnly)
        .unwrap();
    let set = ctx.create_descriptor_set(&p, &[&buf]).unwrap();
    let mut rec = ctx.begin().unwrap();
    rec.bind(&p, set);
    rec.dispatch(2, 1, 1);
    ctx.submit_and_wait(rec).unwrap();
    assert_eq!(ctx.download::<u32>(&buf).unwrap(), vec![42u32; 16]);
    ctx.destroy_buffer(buf);
    ctx.destroy_pipeline(p);
    finish_clean(ctx);
}

#[test]
fn buffers_upload_download_and_misuse() {
    let ctx = context();
    // Every memory location round-trips, mapped and through staging buffers.
    let locations = [
        MemoryLocation::GpuOnly,
        MemoryLocation::CpuToGpu,
        MemoryLocation::GpuToCpu,
    ];
    for (loc, staging) in locations.iter().flat_map(|&l| [(l, false), (l, true)]) {
        ctx.debug_force_staging(staging);
        let data: Vec<u32> = (0..777).map(|i| i * 7 + 1).collect();
        let b = ctx.create_buffer("rt", 777 * 4, STORAGE, loc).unwrap();
        ctx.upload(&b, &data).unwrap();
        assert_eq!(
            ctx.download::<u32>(&b).unwrap(),
            data,
            "{loc:?}, staging {staging}"
        );
        // A partial upload changes only the front.
        ctx.upload(&b, &[5u32, 6]).unwrap();
        let back = ctx.download::<u32>(&b).unwrap();
        assert_eq!((&back[..2], &back[2..]), (&[5u32, 6][..], &data[2..]));
        assert!(
            ctx.upload(&b, &vec![0u32; 778]).is_err(),
            "oversized upload accepted"
        );
        assert!(
            ctx.download::<[u32; 2]>(&b).is_err(),
            "777 words are not whole pairs"
        );
        ctx.destroy_buffer(b);
    }
    // A buffer filled in place (mapped) or through a host vector (staging) holds what the
    // filler wrote, and the filler starts from zeros.
    for staging in [false, true] {
        ctx.debug_force_staging(staging);
        let b = ctx
            .create_buffer_filled("filled", 777, STORAGE, |w: &mut [u32]| {
                assert!(w.iter().all(|&x| x == 0), "staging {staging}: not zeroed");
                for (i, x) in w.iter_mut().enumerate() {
                    *x = i as u32 * 3 + 1;
                }
            })
            .unwrap();
        let want: Vec<u32> = (0..777).map(|i| i * 3 + 1).collect();
        assert_eq!(ctx.download::<u32>(&b).unwrap(), want, "staging {staging}");
        ctx.destroy_buffer(b);
        let empty = ctx
            .create_buffer_filled("filled empty", 0, STORAGE, |w: &mut [u32]| {
                assert!(w.is_empty())
            })
            .unwrap();
        assert!(ctx.download::<u32>(&empty).unwrap().is_empty());
        ctx.destroy_buffer(empty);
    }
    ctx.debug_force_staging(false);
    // Size zero is allowed (rounded up inside).
    let empty = ctx
        .create_buffer("empty", 0, STORAGE, MemoryLocation::GpuOnly)
        .unwrap();
    assert!(ctx.download::<u32>(&empty).unwrap().is_empty());
    let p = ctx
        .create_compute_pipeline("busy", &busy_spirv(), 1, 8)
        .unwrap();
    assert!(
        ctx.create_descriptor_set(&p, &[]).is_err(),
        "wrong number of buffers accepted"
    );
    let set = ctx.create_descriptor_set(&p, &[&empty]).unwrap();
    // Recording errors come back from submit_and_wait, and nothing is submitted.
    let mut rec = ctx.begin().unwrap();
    rec.dispatch(1, 1, 1);
    assert!(format!("{:#}", ctx.submit_and_wait(rec).unwrap_err()).contains("no pipeline bound"));
    let mut rec = ctx.begin().unwrap();
    rec.bind(&p, set);
    rec.push_constants(&p, &[0u32; 4]);
    assert!(format!("{:#}", ctx.submit_and_wait(rec).unwrap_err()).contains("push_constants"));
    let mut rec = ctx.begin().unwrap();
    rec.bind(&p, set);
    rec.dispatch_indirect(&empty, 0);
    assert!(format!("{:#}", ctx.submit_and_wait(rec).unwrap_err()).contains("INDIRECT_BUFFER"));
    assert!(ctx
        .create_compute_pipeline("too_many", &busy_spirv(), 1, 132)
        .is_err());
    ctx.destroy_buffer(empty);
    ctx.destroy_pipeline(p);
    finish_clean(ctx);
}

#[test]
fn descriptor_sets_are_freed_with_their_pipeline() {
    let ctx = context();
    let spirv = busy_spirv();
    let buf = ctx
        .create_buffer("b", 256, STORAGE, MemoryLocation::GpuOnly)
        .unwrap();
    let mut pools = Vec::new();
    for round in 0..3 {
        let p = ctx.create_compute_pipeline("sets", &spirv, 1, 0).unwrap();
        // More sets than one pool holds (64).
        for _ in 0..150 {
            ctx.create_descriptor_set(&p, &[&buf]).unwrap();
        }
        pools.push(ctx.debug_descriptor_pool_count());
        ctx.destroy_pipeline(p);
        assert!(
            round < 1 || pools[round] == pools[0],
            "pools grow: {pools:?}"
        );
    }
    assert!(pools[0] >= 3, "{pools:?}");
    ctx.destroy_buffer(buf);
    finish_clean(ctx);
}

#[test]
fn leaks_are_reported_and_cleaned_up() {
    let ctx = context();
    let b = ctx
        .create_buffer("forgotten", 64, STORAGE, MemoryLocation::GpuOnly)
        .unwrap();
    drop(b);
    let p = ctx
        .create_compute_pipeline("forgotten_pipeline", &busy_spirv(), 1, 0)
        .unwrap();
    // Destroying by reference twice is harmless; a pipeline never destroyed is reported.
    let p2 = ctx
        .create_compute_pipeline("twice", &busy_spirv(), 1, 0)
        .unwrap();
    ctx.destroy_pipeline_ref(&p2);
    ctx.destroy_pipeline_ref(&p2);
    std::mem::forget(p);
    let msgs = ctx.finish();
    assert_eq!(msgs.len(), 2, "{msgs:?}");
    assert!(
        msgs.iter().any(|m| m.contains("buffer \"forgotten\"")),
        "{msgs:?}"
    );
    assert!(
        msgs.iter()
            .any(|m| m.contains("pipeline \"forgotten_pipeline\"")),
        "{msgs:?}"
    );
}
