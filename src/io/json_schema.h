/*
 * json_schema.h: a small JSON Schema validator for the subset of draft
 * 2020-12 that dtx's own schemas use.
 *
 * Supported keywords:
 *   type (a name or an array of names; "integer" is a number with no
 *     fractional part), enum, const,
 *   properties, required, additionalProperties (a schema, true or false),
 *   items (one schema for every element), minItems, maxItems,
 *   minLength, maxLength (counted in bytes),
 *   minimum, maximum, exclusiveMinimum, exclusiveMaximum (numbers),
 *   pattern (POSIX extended regular expression, unanchored like ECMA),
 *   oneOf, anyOf, $ref ("#" or "#/json/pointer", usually "#/$defs/NAME"),
 *   boolean schemas (true accepts everything, false nothing).
 * Ignored annotations: $schema, $id, $comment, $defs, title, description,
 * default, examples.  Any other keyword is a schema error (DTX_EINVAL), so
 * a schema cannot silently rely on something this validator skips.
 *
 * Beyond JSON Schema, two things every dtx document must satisfy are
 * checked: an object may not repeat a key, and numbers must be finite
 * (cJSON turns 1e999 into infinity).
 */
#ifndef DTX_JSON_SCHEMA_H
#define DTX_JSON_SCHEMA_H

#include "status.h"

#include <cjson/cJSON.h>
#include <stddef.h>

/* Validates doc against schema (both parsed by cJSON; schema is the root
 * that "$ref": "#/..." resolves against).
 *
 * Returns DTX_OK when doc is valid.  Otherwise returns DTX_EJOB and writes
 * to msg (msgsize bytes including the NUL, truncated if needed; msg may be
 * NULL when msgsize is 0) one sentence naming the place as a JSON pointer,
 * what was expected and what was found, e.g.
 *   at /output/dtype: expected one of float32, float64, got "float16"
 *   at /source: missing required key "mesh"
 * Only the first error is reported, and it is the first in document
 * order: a value's own checks (type, enum, const, range, length, item
 * count) come first, then its members in document order (a repeated key,
 * an unknown key or a member's own errors, found where the member is), then
 * the required keys that are missing (as if at the object's closing
 * brace, in the order of "required"), then oneOf / anyOf.  When no branch
 * of a oneOf / anyOf matches, the error of the branch that fits best (most
 * of its "required" keys present, then the deepest error) is reported,
 * followed by "(for TITLE)" when the branch has a title; when no branch
 * fits better than the others, one sentence lists every branch's error.
 *
 * Returns DTX_EINVAL (with a message) when the schema itself uses an
 * unsupported keyword, has a bad value for a keyword, an unresolvable $ref,
 * a $ref loop that does not go deeper into the document, or an invalid
 * pattern; also DTX_EINVAL when validation exceeds its step limit (256
 * steps per document value, at least 100,000), and DTX_ENOMEM when out of
 * memory.
 *
 * Thread-safe (no global state; regular expressions are compiled per call).
 */
dtx_status dtx_json_validate(const cJSON *schema, const cJSON *doc, char *msg, size_t msgsize);

/* Appends the JSON pointer escape of key (RFC 6901: "~" -> "~0",
 * "/" -> "~1") preceded by "/" to the NUL-terminated string in buf
 * (bufsize bytes), truncating if needed.  Used to name places in messages. */
void dtx_json_pointer_append(char *buf, size_t bufsize, const char *key);

/* ------------------------------------------------------------------
 * Checks on the JSON text itself, for what cJSON cannot report well.
 */

/* The deepest nesting of arrays and objects a dtx document may have.  dtx's
 * own documents nest a handful of levels; the limit is far below cJSON's
 * own (CJSON_NESTING_LIMIT), whose failure reads as a plain syntax error. */
#define DTX_JSON_MAX_DEPTH 64

/* The offset in [text, text + len) of the first '[' or '{' (outside
 * strings) that opens level max_depth + 1, or (size_t)-1 when the text
 * nests no deeper than max_depth.  Works on any text: it only follows
 * strings and brackets, so it can run before the text is parsed. */
size_t dtx_json_find_too_deep(const char *text, size_t len, int max_depth);

/* In text that cJSON has parsed successfully, the offset of the first
 * string (a member name or a value) holding the escape \u0000, or
 * (size_t)-1 when there is none.  cJSON decodes it to a NUL byte and the C
 * string then ends there ("sp04\u0000x" would read as "sp04"), so dtx
 * refuses such strings.  When found, ptr (ptrsize bytes) receives the JSON
 * pointer of the value, or of the member whose name holds it ("" for the
 * top level), truncated if needed. */
size_t dtx_json_find_nul_escape(const char *text, size_t len, char *ptr, size_t ptrsize);

/* The 1-based line and column of offset pos in text (lines end at "\n",
 * "\r\n" or a lone "\r"; columns count bytes). */
void dtx_json_line_col(const char *text, size_t len, size_t pos, size_t *line, size_t *col);

#endif /* DTX_JSON_SCHEMA_H */
