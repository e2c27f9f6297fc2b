# Installs the Khronos glTF validator (npm package `gltf-validator`) into the build tree for the
# export tests: cmake -DNPM=... -DPREFIX=... -DVERSION=... -DSTAMP=... -P install_gltf_validator.cmake
# A failed install (e.g. no network) is reported but does not fail the build: the validator test
# then fails with its own message naming what is missing, and the next build tries again.
execute_process(
  COMMAND "${NPM}" install --prefix "${PREFIX}" --no-audit --no-fund --fetch-retries=1 "gltf-validator@${VERSION}"
  RESULT_VARIABLE rc)
if(rc EQUAL 0 AND EXISTS "${PREFIX}/node_modules/gltf-validator/package.json")
  file(TOUCH "${STAMP}")
else()
  message(WARNING "npm install gltf-validator@${VERSION} into ${PREFIX} failed (${rc}); "
                  "the export tests' glTF validation will fail until it succeeds")
endif()
