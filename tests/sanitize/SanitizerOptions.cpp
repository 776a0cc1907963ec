// The sanitizers' defaults for every program of the sanitizer run (tests/sanitize), read by their runtimes at start,
// so that they hold however the program is started (ctest, gtest's test listing, the ingest fuzzer's runs).
// abort_on_error: a finding ends the program with SIGABRT, never with exit status 1, which the ingest fuzzer reads as
// a clean refusal. allocator_may_return_null: malloc of more than the sanitizer's allocator gives returns null, as C
// libraries expect (operator new still ends the program: the readers must refuse such a size before allocating).
// detect_leaks=0: the run looks for memory errors and undefined behaviour; the GL driver and the libraries keep
// memory until exit.
extern "C" const char* __asan_default_options() {
  return "abort_on_error=1:allocator_may_return_null=1:detect_leaks=0";
}
extern "C" const char* __ubsan_default_options() { return "abort_on_error=1:print_stacktrace=1"; }
