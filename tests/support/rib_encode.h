/* rib_encode.h — a test-side encoder from ASCII RIB to binary RIB (RI Spec 3.2, Appendix C.2,
 * Table C.1), written apart from the reader's lexer so that the two check each other
 * (tests/test_rib_binary.c). It has its own ASCII tokenizer and writes every token in an
 * encoding that decodes to exactly the double the ASCII text gives (strtod): integers and
 * fixed-point numbers where they are exact, else IEEE floats where exact, else doubles;
 * float arrays (0310-0313) where every element is a float; requests through 0314/0246;
 * strings seen more than once through 0315/0316 and 0317/0320, others as 0220-0243. */
#ifndef TS_TEST_RIB_ENCODE_H
#define TS_TEST_RIB_ENCODE_H

#include <stddef.h>

typedef enum rib_encode_mode {
    RIB_ENCODE_BINARY, /* every request binary */
    RIB_ENCODE_MIXED,  /* every other request left as its ASCII text */
} rib_encode_mode;

/* Encodes len bytes of ASCII RIB; a malloc'd buffer of *out_len bytes, or NULL (with a
 * message on stderr) for text it cannot tokenize. */
unsigned char *rib_encode(const char *text, size_t len, rib_encode_mode mode, size_t *out_len);

#endif
