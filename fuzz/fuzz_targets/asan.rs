//! AddressSanitizer's default options for every target: the vendored meshoptimizer C++
//! (linked through tessera-preprocess, reached by no importer) defines a global `edges` twice,
//! which ASan's ODR check refuses at start-up. `ASAN_OPTIONS` still overrides this.

#[no_mangle]
pub extern "C" fn __asan_default_options() -> *const std::ffi::c_char {
    c"detect_odr_violation=0".as_ptr()
}
