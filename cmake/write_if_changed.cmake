# esr_write_if_changed(PATH TEXT): writes TEXT to PATH only when it differs from what PATH holds, so a
# generated source that has not changed rebuilds nothing (cmake/version.cmake, cmake/embed.cmake).
function(esr_write_if_changed path text)
  if(EXISTS "${path}")
    file(READ "${path}" old)
  else()
    set(old "")
  endif()
  if(NOT old STREQUAL text)
    file(WRITE "${path}" "${text}")
  endif()
endfunction()
