extern crate brdfwave;
fn main() { let c = shaderc::Compiler::new().unwrap(); let r = c.compile_into_spirv("#version 450\nlayout(local_size_x=1) in; void main(){}", shaderc::ShaderKind::Compute, "t.comp", "main", None).unwrap(); println!("{}", r.as_binary().len()); let _ = unsafe { ash::Entry::load() }.unwrap(); }
