/*
 * oiio_lsan.h - the sanitizer settings of a test program that feeds
 * damaged PNG files to the OpenImageIO module (tests/test_native_read.c,
 * tests/fuzz/fuzz_imageio.c).  Include it in one file of the program: it
 * defines the functions the sanitizer runtime looks up.
 *
 * LeakSanitizer: OpenImageIO 2.4.7's PNG reader loses a std::string (31
 * bytes) on every truncated PNG - PngReadCallback builds an error message
 * and libpng longjmps past its destructor.  Not ours to fix and bounded
 * per file, so exactly that stack is ignored.  The suppression needs the
 * allocation's whole stack: libstdc++ has no frame pointers, so the fast
 * unwinder stops inside it.
 */
#ifndef GV_TESTS_OIIO_LSAN_H
#define GV_TESTS_OIIO_LSAN_H

const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void)
{
    return "leak:OpenImageIO_v2_4::PNGInput::PngReadCallback\n";
}

const char *__asan_default_options(void);
const char *__asan_default_options(void)
{
    return "fast_unwind_on_malloc=0";
}

#endif
