//! Helpers shared by the reader tests.

pub use ratfit_tests::data_dir;

/// Byte offset, element width and element count of field `name`.
pub fn tensor_field(bytes: &[u8], name: &str) -> (usize, usize, usize) {
    let count = u32::from_le_bytes(bytes[14..18].try_into().unwrap()) as usize;
    let mut pos = 18;
    for _ in 0..count {
        let len = u16::from_le_bytes([bytes[pos], bytes[pos + 1]]) as usize;
        let field = &bytes[pos + 2..pos + 2 + len];
        pos += 2 + len;
        let ndim = u16::from_le_bytes([bytes[pos], bytes[pos + 1]]) as usize;
        let dtype = bytes[pos + 2];
        let offset = u64::from_le_bytes(bytes[pos + 3..pos + 11].try_into().unwrap()) as usize;
        let n: usize = (0..ndim)
            .map(|k| {
                let at = pos + 11 + 8 * k;
                u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize
            })
            .product();
        pos += 11 + 8 * ndim;
        if field == name.as_bytes() {
            let width = match dtype {
                10 => 4,
                11 => 8,
                1 | 2 => 1,
                3 | 4 => 2,
                5 | 6 => 4,
                _ => 8,
            };
            return (offset, width, n);
        }
    }
    panic!("no field {name}");
}
