"""The ingest fuzzer's parts (seeds, mutations, the checks); fuzz_ingest.py beside them runs them."""
