from fabpat.cli import main

main()
