# Shared by the batch tests (sourced): a small JW manifest and a comparison of two output trees.

# write_manifest <file> <source dir> <data dir> <folder for the corrupt C3D>: three rows. s1/ngait_og3
# through IK and the workflow (contact area, measured force, Hertz fit); s2/ngait_og1 through IK and
# the contact area; s1/corrupt, ngait_og7's C3D cut short, which must fail alone.
write_manifest() {
  m=$1 src=$2 data=$3 bad=$4
  head -c 30000 "$data/kgc4-jw/markers/jw_ngait_og7.c3d" >"$bad/jw_corrupt.c3d"
  model="$src/models/jw-knee24/jw_knee24.osim"
  tasks="$src/models/jw-knee24/jw_knee24_ik_tasks.xml"
  jw="$data/kgc4-jw"
  implant="$jw/implant/femoral_component.stl,$jw/implant/tibial_insert.stl,femoral_component,tibial_insert"
  {
    echo "subject,trial,activity,tools,model,ik_tasks,markers,knee_forces,femoral_component,insert,femoral_mesh,insert_mesh,body_mass"
    echo "s1,ngait_og3,gait,ik workflow,$model,$tasks,$jw/markers/jw_ngait_og3.c3d,$jw/knee-forces/jw_ngait_og3_knee_forces.csv,$implant,66.7"
    echo "s2,ngait_og1,gait,ik contact,$model,$tasks,$jw/markers/jw_ngait_og1.c3d,,$implant,66.7"
    echo "s1,corrupt,gait,ik,$model,$tasks,$bad/jw_corrupt.c3d,,,,,,66.7"
  } >"$m"
}

# same_outputs <tree A> <tree B>: the same files with the same bytes, except what records run
# times (logs, completion markers) and the summary's status and seconds columns (done or
# done-earlier). Prints what differs.
same_outputs() {
  a=$1 b=$2 ok=0
  la=$(cd "$a" && find . -type f ! -name '*.log' ! -name '*.done' ! -name batch_summary.csv | sort)
  lb=$(cd "$b" && find . -type f ! -name '*.log' ! -name '*.done' ! -name batch_summary.csv | sort)
  if [ "$la" != "$lb" ]; then
    echo "different files: $(printf '%s\n' "$la" | tr '\n' ' ') / $(printf '%s\n' "$lb" | tr '\n' ' ')"
    ok=1
  fi
  for f in $la; do
    cmp -s "$a/$f" "$b/$f" || { echo "differs: $f"; ok=1; }
  done
  if [ -f "$a/batch_summary.csv" ] || [ -f "$b/batch_summary.csv" ]; then
    cut -d, -f1-3,6- "$a/batch_summary.csv" >"$a.summary.cut" 2>/dev/null
    cut -d, -f1-3,6- "$b/batch_summary.csv" >"$b.summary.cut" 2>/dev/null
    cmp -s "$a.summary.cut" "$b.summary.cut" || { echo "differs: batch_summary.csv (status and seconds aside)"; ok=1; }
    rm -f "$a.summary.cut" "$b.summary.cut"
  fi
  return $ok
}
