"""The ingest fuzzer's parts (seeds, mutations, the checks); bench/fuzz_ingest.py runs them."""
